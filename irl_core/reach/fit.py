"""The fit of a reach world (docs/reach.md): each symbol's points and the spread law, with intervals.

Two likelihoods, fitted one after the other:

1. **The spread law**, from where reaches ended around where they were aimed. Residual r_i = endpoint_i - aim_i
   is normal with sd_i = a + b * x_i per axis, x_i = distance_i / (duration_i / 1000); (a, b) by maximum
   likelihood, intervals by the Laplace approximation (the inverse of the negative log-likelihood's Hessian at
   the maximum). With `spread_known`, or when every reach has the same x (a and b cannot be told apart), the
   world's own law is used and said so.
2. **The points**, from where the player aimed and how long they took. The player is soft-optimal over the
   `ChoiceGrid` built with that spread law: choice (k, j) with probability pi[k, j] = exp(beta EG[k, j]) / Z,
   then an aim error of their own, N(0, sigma^2) per axis. A trial's duration is read as its nearest grid
   duration j_i, and its likelihood is sum_k pi[k, j_i] N(aim_i; aim_k, sigma^2 I). The unknowns are the
   points w (one a symbol), log beta and log sigma; the known time cost fixes the points' scale.
   Maximised with L-BFGS-B and the exact gradient; intervals by the Laplace approximation over all of them
   (``interval_kind: "confidence"``, ``interval_method: "laplace"``).

   When every trial is the same grid choice (the expected-gain maximiser), the likelihood grows without end
   as beta grows, and its limit says only that this choice is the best one. careful then reports exactly
   that: the set of points for which the choice is the grid's best (linear in w, two LPs a symbol, bounded
   by +-rmax), with the point of largest margin inside it (``interval_kind: "identified"``).

Every point lies inside its interval.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linprog, minimize
from scipy.special import logsumexp
from scipy.stats import norm

from irl_core.errors import BadInputError, SolverError
from irl_core.reach.gain import ChoiceGrid, choice_grid
from irl_core.recordings.reach_reader import Reaches
from irl_core.worlds.reach import ReachWorld, Spread

RMAX = 1e5
# beta and sigma are searched within these (beta in 1 / points, sigma in grid steps): beyond them the choices
# are a single grid point, which the identified branch handles.
BETA_RANGE = (1e-6, 1e3)
SIGMA_STEPS = (0.25, 64.0)
# Below this share of the largest |points| fitted, the spread of the time cost over the allowed durations is
# said not to fix the points' scale (a world whose limits leave one duration: no care to choose).
WEAK_SCALE = 0.01
# Under this many trials (one choice each, against four or more unknowns) a fit says its intervals are rough:
# the grid's few_episodes note, for reaches.
FEW_TRIALS = 30


@dataclass(frozen=True)
class Note:
    """A stable `code` beside a sentence, as the grid fit's notes."""

    code: str
    text: str


@dataclass(frozen=True)
class SpreadFit:
    """The spread law a fit used: fitted (with its intervals and the covariance (2, 2) of (a, b)) or `known`."""

    spread: Spread
    interval: dict[str, tuple[float, float]] | None
    known: bool
    covariance: np.ndarray | None = None


@dataclass(frozen=True)
class ReachFit:
    """A reach fit's answer: points and intervals per symbol, the spread law, the player's beta and sigma."""

    world: ReachWorld
    reward: dict[str, float]
    interval: dict[str, tuple[float, float]]
    interval_kind: str
    interval_method: str
    spread: SpreadFit
    beta: float | None
    aim_sd: float | None
    confidence: float
    trials: int
    files: int
    notes: list[Note] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """The fit as the JSON `careful fit --json` writes (docs/reach.md)."""
        return {
            "method": "reach",
            "world": self.world.model_dump(mode="json"),
            "options": {"confidence": self.confidence, "spread_known": self.spread.known, "rmax": RMAX},
            "trials": self.trials,
            "files": self.files,
            "reward": self.reward,
            "interval": {symbol: list(bounds) for symbol, bounds in self.interval.items()},
            "interval_kind": self.interval_kind,
            "interval_method": self.interval_method,
            "spread": {"a": self.spread.spread.a, "b": self.spread.spread.b,
                       "interval": None if self.spread.interval is None
                       else {name: list(bounds) for name, bounds in self.spread.interval.items()},
                       "known": self.spread.known},
            "player": {"beta": self.beta, "aim_sd": self.aim_sd},
            "notes": [{"code": note.code, "text": note.text} for note in self.notes],
        }


def fit_reaches(reaches: Reaches, *, spread_known: bool = False, confidence: float = 0.95,
                known: dict[str, float] | None = None) -> ReachFit:
    """Fit each symbol's points (and the spread law unless `spread_known`) to the trials; the symbols in `known`
    are held at their value (their interval is that value).

    Raises `BadInputError` when nothing fixes the points' scale (a world whose time costs nothing), and
    `SolverError` when an LP of the identified set fails."""
    world = reaches.world
    known = known or {}
    if world.cost_per_second == 0:
        raise BadInputError("the world's time costs nothing (cost_per_second = 0), so nothing fixes the points' "
                            "scale: only their ratios could be fitted", code="cost_free")
    unknown = [symbol for symbol in world.symbols if symbol not in known]
    if not unknown:
        raise BadInputError("every symbol's points are given as known: there is nothing to fit", code="nothing_to_fit")
    notes: list[Note] = []
    if reaches.trials < FEW_TRIALS:
        notes.append(Note("few_episodes", f"only {reaches.trials} trials: intervals from so few are rough (a Laplace "
                          "interval tends to be too narrow, and an identified set may rest on a choice so few trials "
                          "do not show to be the player's)"))
    spread = fit_spread(reaches, known=spread_known, confidence=confidence, notes=notes)
    grid = choice_grid(world, spread=spread.spread)
    cost_span = float(np.ptp(grid.cost))
    free = [world.symbols.index(symbol) for symbol in unknown]
    fixed = np.array([known.get(symbol, 0.0) for symbol in world.symbols])
    hits, cost = _unknown_tables(grid, free, fixed)
    columns = grid.nearest_duration(reaches.durations)
    cells = _grid_cells(grid, reaches.aims)
    z = float(norm.ppf(0.5 + confidence / 2))
    reward = {symbol: float(value) for symbol, value in known.items() if symbol in world.symbols}
    interval = {symbol: (float(value), float(value)) for symbol, value in reward.items()}
    if len(set(zip(cells.tolist(), columns.tolist()))) == 1 and np.all(grid.aims[cells] == reaches.aims):
        point, bounds = identified_set(hits, cost, int(cells[0]), int(columns[0]))
        notes.append(Note("one_choice", "every trial is the same choice (an expected-gain maximiser): the points "
                          "are every value for which that choice is the best, the point the one of largest margin"))
        reward |= dict(zip(unknown, point.tolist()))
        interval |= {symbol: (float(low), float(high)) for symbol, (low, high) in zip(unknown, bounds)}
        return ReachFit(world, _ordered(world, reward), _ordered(world, interval), "identified", "identified set",
                        spread, None, None, confidence, reaches.trials, reaches.files, notes)
    spread_effect = None
    if spread.covariance is not None:
        spread_covariance = spread.covariance

        def spread_effect(params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return _spread_cross(reaches, spread.spread, free, fixed, columns, params), spread_covariance

    theta, covariance = _soft_fit(grid, hits, cost, reaches.aims, columns, spread_effect)
    count = len(unknown)
    beta = float(theta[count])
    if beta <= BETA_RANGE[0] * 1.001:
        notes.append(Note("scale_not_identified", "the player's choices say little about the time cost (beta at its "
                          "smallest), so the points' scale is barely pinned: they may be far larger than shown"))
    se = np.sqrt(np.diag(covariance)[:count]) if covariance is not None else np.full(count, np.inf)
    if not np.all(np.isfinite(se)):
        notes.append(Note("laplace_singular", "the likelihood is flat in some direction at its maximum: the "
                          "intervals are the whole range +-rmax"))
        se = np.full(count, np.inf)
    point = np.clip(theta[:count], -RMAX, RMAX)
    low, high = np.clip(point - z * se, -RMAX, RMAX), np.clip(point + z * se, -RMAX, RMAX)
    if not known and cost_span < WEAK_SCALE * np.abs(point).max():
        # The likelihood's curvature still gives a narrow interval here, but along the scale it is far from
        # quadratic: measured (bench_reach, limits narrowed to one duration) 1-2 of 19 such intervals held the truth.
        notes.append(Note("scale_not_identified", f"the durations the world allows differ in cost by {cost_span:.3g} "
                          f"points at most, under {WEAK_SCALE:.0%} of the points fitted: the time cost hardly fixes "
                          "their scale, so every interval is the whole range; give one symbol's points with --known"))
        low, high = np.full(count, -RMAX), np.full(count, RMAX)
    reward |= dict(zip(unknown, point.tolist()))
    interval |= {symbol: (float(lo), float(hi)) for symbol, lo, hi in zip(unknown, low, high)}
    return ReachFit(world, _ordered(world, reward), _ordered(world, interval), "confidence", "laplace", spread,
                    beta, float(theta[count + 1]), confidence, reaches.trials, reaches.files, notes)


def fit_spread(reaches: Reaches, *, known: bool, confidence: float, notes: list[Note]) -> SpreadFit:
    """The spread law: the world's when `known` (or when the trials cannot tell a from b), else the maximum
    likelihood (a, b) of the endpoints' scatter with Laplace intervals (b's kept at 0 or above)."""
    world = reaches.world
    if known:
        return SpreadFit(world.spread, None, True)
    x = world.distance(reaches.aims) / (reaches.durations / 1000.0)
    squared = ((reaches.endpoints - reaches.aims) ** 2).sum(axis=1)
    if np.ptp(x) <= 1e-9 * max(1.0, float(np.abs(x).max())):
        notes.append(Note("spread_not_identified", "every reach has the same distance and duration, so the spread "
                          "law's a and b cannot be told apart: the world's own law is used"))
        return SpreadFit(world.spread, None, True)

    def negative_log_likelihood(params: np.ndarray) -> tuple[float, np.ndarray]:
        a, b = params
        sd = a + b * x
        value = float(np.sum(2 * np.log(sd) + squared / (2 * sd**2)))
        d_sd = 2 / sd - squared / sd**3
        return value, np.array([d_sd.sum(), (d_sd * x).sum()])

    scale = float(np.sqrt(squared.mean() / 2))
    found = minimize(negative_log_likelihood, np.array([scale / 2, scale / 2 / max(float(x.mean()), 1e-9)]), jac=True,
                     method="L-BFGS-B", bounds=[(1e-6, None), (0.0, None)])
    a, b = (float(v) for v in found.x)
    sd = a + b * x
    # The Hessian of the negative log-likelihood in (a, b): d2/dsd2 = -2/sd^2 + 3 r^2/sd^4, chained through x.
    curvature = -2 / sd**2 + 3 * squared / sd**4
    hessian = np.array([[curvature.sum(), (curvature * x).sum()], [(curvature * x).sum(), (curvature * x**2).sum()]])
    z = float(norm.ppf(0.5 + confidence / 2))
    try:
        covariance: np.ndarray | None = np.linalg.inv(hessian)
    except np.linalg.LinAlgError:
        covariance = None
    se = np.array([np.inf, np.inf]) if covariance is None else np.sqrt(np.clip(np.diag(covariance), 0, None))
    interval = {"a": (max(a - z * se[0], 1e-6), a + z * se[0]), "b": (max(b - z * se[1], 0.0), b + z * se[1])}
    return SpreadFit(Spread(a=max(a, 1e-6), b=b), interval, False,
                     covariance if covariance is not None and np.all(np.isfinite(covariance)) else None)


def _unknown_tables(grid: ChoiceGrid, free: list[int], fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """hits (F, K, D) of the unknown symbols (`free`, indices of `world.symbols`), and the cost (K, D): the time
    cost less the expected points of the known symbols (`fixed` (S,), zero where unknown)."""
    return grid.hits[free], grid.cost[None, :] - np.tensordot(fixed, grid.hits, axes=1)


def _spread_cross(reaches: Reaches, law: Spread, free: list[int], fixed: np.ndarray, columns: np.ndarray,
                  params: np.ndarray) -> np.ndarray:
    """(P, 2) d/d(a, b) of the soft objective's gradient at params: central differences over the spread law
    (one-sided at b = 0), each a grid rebuilt with the law moved."""
    cross = np.empty((len(params), 2))
    for column, name in enumerate(("a", "b")):
        value = getattr(law, name)
        step = 1e-3 * max(value, 1e-2)
        low = max(value - step, 1e-6 if name == "a" else 0.0)
        gradients = []
        for moved in (value + step, low):
            grid = choice_grid(reaches.world, spread=law.model_copy(update={name: moved}))
            hits, cost = _unknown_tables(grid, free, fixed)
            gradients.append(soft_objective(grid, hits, cost, reaches.aims, columns)(params)[1])
        cross[:, column] = (gradients[0] - gradients[1]) / (value + step - low)
    return cross


def _grid_cells(grid: ChoiceGrid, aims: np.ndarray) -> np.ndarray:
    """(n,) the index of the grid aim nearest each aim (n, 2)."""
    origin = grid.aims.min(axis=0)
    counts = np.round((grid.aims.max(axis=0) - origin) / grid.step).astype(int) + 1
    index = np.clip(np.round((aims - origin) / grid.step).astype(int), 0, counts - 1)
    return index[:, 0] * counts[1] + index[:, 1]


def soft_objective(grid: ChoiceGrid, hits: np.ndarray, cost: np.ndarray, aims: np.ndarray,
                   columns: np.ndarray) -> Callable[[np.ndarray], tuple[float, np.ndarray]]:
    """The soft-optimal player's negative log-likelihood of the trials and its gradient, as a function of
    params = (v (F), beta, log sigma) with v = beta * w, for EG[k, j] = w . hits[:, k, j] - cost[k, j] (hits
    (F, K, D) of the F unknown symbols; cost (K, D) the time cost less the known symbols' expected points);
    aims (n, 2) and columns (n,) the trials' aims and grid durations."""
    symbols, n = hits.shape[0], len(columns)
    xs, ys = np.unique(grid.aims[:, 0]), np.unique(grid.aims[:, 1])  # the lattice: aim k = (xs[k // ny], ys[k % ny])
    dx2 = (aims[:, 0, None] - xs[None, :]) ** 2  # (n, nx)
    dy2 = (aims[:, 1, None] - ys[None, :]) ** 2  # (n, ny)
    shape = (len(xs), len(ys), hits.shape[2])
    groups = [(j, np.flatnonzero(columns == j)) for j in np.unique(columns)]
    # The aim error is separable: sum_k pi[k, j] N(aim; aim_k) = A_i^T Pi_j B_i with A, B its x and y factors,
    # so every per-trial sum over the lattice is a matrix product.
    tables = [hit.reshape(shape) for hit in hits] + [cost.reshape(shape)]

    def negative_log_likelihood(params: np.ndarray) -> tuple[float, np.ndarray]:
        v, beta, sigma = params[:symbols], params[symbols], np.exp(params[symbols + 1])
        scaled = np.tensordot(v, hits, axes=1) - beta * cost  # (K, D)
        log_pi = scaled - logsumexp(scaled)
        pi = np.exp(log_pi).reshape(shape)
        a_x, b_y = np.exp(-dx2 / (2 * sigma**2)), np.exp(-dy2 / (2 * sigma**2))
        likelihood = np.empty(n)
        # sums[t][i] = sum_k r_ik table_t[k, j_i] (t over the hits, then cost), times L_i; spread_sum the same for d^2
        sums = np.empty((len(tables), n))
        spread_sum = np.empty(n)
        for j, rows in groups:
            a, b = a_x[rows], b_y[rows]
            weighted = a @ pi[:, :, j]  # (m, ny)
            likelihood[rows] = (weighted * b).sum(axis=1)
            for t, table in enumerate(tables):
                sums[t, rows] = ((a @ (pi[:, :, j] * table[:, :, j])) * b).sum(axis=1)
            spread_sum[rows] = (((a * dx2[rows]) @ pi[:, :, j]) * b).sum(axis=1) + (weighted * b * dy2[rows]).sum(axis=1)
        likelihood = np.maximum(likelihood, 1e-300)
        means = sums / likelihood  # (T, n): the expected table value given the trial's aim and duration
        pi_flat = pi.reshape(-1, shape[2])
        d_v = means[:symbols].sum(axis=1) - n * (hits * pi_flat).sum(axis=(1, 2))
        d_beta = -(means[symbols].sum() - n * float((cost * pi_flat).sum()))
        d_sigma = float((spread_sum / likelihood).sum() / sigma**2 - 2 * n)
        value = float(np.log(likelihood).sum()) - n * (2 * np.log(sigma) + np.log(2 * np.pi))
        return -value, -np.concatenate([d_v, [d_beta, d_sigma]])

    return negative_log_likelihood


def _soft_fit(grid: ChoiceGrid, hits: np.ndarray, cost: np.ndarray, aims: np.ndarray, columns: np.ndarray,
              spread_effect: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """theta = (w (F), beta, sigma) of largest likelihood, and the Laplace covariance of (w, beta, log sigma)
    (None if singular), `soft_objective`'s arguments.

    `spread_effect(params)`, when the spread law was fitted, gives the cross derivatives (P, 2) of the negative
    log-likelihood in params and the law's (a, b) and the law's covariance (2, 2): the covariance then carries
    the law's uncertainty too (the two-step correction of Murphy & Topel 1985: V = H^-1 + H^-1 C V_ab C' H^-1).

    Searched as (v = beta * w, beta, log sigma): there beta * EG = v . H - beta * cost is linear, the choice's
    log-likelihood concave, and a small beta does not silence the gradient in the points."""
    symbols = hits.shape[0]
    negative_log_likelihood = soft_objective(grid, hits, cost, aims, columns)
    bounds = [(None, None)] * symbols + [BETA_RANGE] + [tuple(np.log(np.array(SIGMA_STEPS) * grid.step))]
    start = np.concatenate([np.zeros(symbols), [BETA_RANGE[0] * 1e3, np.log(grid.step)]])
    found = minimize(negative_log_likelihood, start, jac=True, method="L-BFGS-B", bounds=bounds,
                     options={"maxiter": 5000})
    params = found.x
    beta = params[symbols]
    theta = np.concatenate([params[:symbols] / beta, [beta, np.exp(params[symbols + 1])]])
    # The Hessian by central differences of the exact gradient, symmetrised; then the delta method to (w, beta, log sigma).
    steps = 1e-5 * np.maximum(1.0, np.abs(params))
    hessian = np.empty((len(params), len(params)))
    for i, h in enumerate(steps):
        up, down = params.copy(), params.copy()
        up[i] += h
        down[i] -= h
        hessian[i] = (negative_log_likelihood(up)[1] - negative_log_likelihood(down)[1]) / (2 * h)
    hessian = (hessian + hessian.T) / 2
    try:
        covariance = np.linalg.inv(hessian)
    except np.linalg.LinAlgError:
        return theta, None
    if spread_effect is not None:
        cross, spread_covariance = spread_effect(params)
        covariance = covariance + covariance @ cross @ spread_covariance @ cross.T @ covariance
    jacobian = np.eye(len(params))
    jacobian[:symbols, :symbols] /= beta
    jacobian[:symbols, symbols] = -params[:symbols] / beta**2
    covariance = jacobian @ covariance @ jacobian.T
    return theta, covariance if np.all(np.diag(covariance) > 0) else None


def identified_set(hits: np.ndarray, cost: np.ndarray, cell: int, column: int) -> tuple[np.ndarray, np.ndarray]:
    """The points w (F,) of largest margin for which choice (cell, column) is the grid's best, and each unknown's
    smallest and largest such value (F, 2), within +-RMAX, for EG = w . hits - cost (hits (F, K, D), cost (K, D)
    as `_soft_fit`'s). EG is linear in w, so each is an LP.

    Raises `SolverError` when an LP fails."""
    chosen = cell * hits.shape[2] + column
    costs = cost.ravel()
    hits = hits.reshape(hits.shape[0], -1)  # (F, K*D)
    others = np.arange(hits.shape[1]) != chosen
    # EG_chosen - EG_other = (H_chosen - H_other) . w - (c_chosen - c_other) >= margin
    rows = (hits[:, chosen, None] - hits[:, others]).T  # (M, S)
    rhs = costs[chosen] - costs[others]  # (M,)
    symbols = hits.shape[0]
    # max margin t (capped at 1 point: beyond it the LP would only chase the bound)
    margin_rows = np.hstack([rows, -np.ones((len(rhs), 1))])
    found = _lp_with_cuts(np.r_[np.zeros(symbols), -1.0], margin_rows, rhs, [(-RMAX, RMAX)] * symbols + [(None, 1.0)])
    if found[-1] < 0:
        raise SolverError("no points make the recorded choice the grid's best", code="identified_set_failed")
    point = found[:symbols]
    interval = np.empty((symbols, 2))
    for s in range(symbols):
        for side, sign in enumerate((1.0, -1.0)):
            objective = np.zeros(symbols)
            objective[s] = sign
            interval[s, side] = _lp_with_cuts(objective, rows, rhs, [(-RMAX, RMAX)] * symbols)[s]
    return point, interval


# The cutting-plane LPs start from the rows of this many nearest choices and add at most this many violated
# rows a round: of the grid's 100,000-odd rows a handful bind.
_FIRST_ROWS = 2000
_ROWS_A_ROUND = 500
_MAX_ROUNDS = 200


def _lp_with_cuts(objective: np.ndarray, rows: np.ndarray, rhs: np.ndarray, bounds: list) -> np.ndarray:
    """argmin objective . x subject to rows @ x >= rhs (M rows) within `bounds`, solved on a growing subset of the
    rows (those violated are added until none is). Raises `SolverError` when an LP fails."""
    closeness = np.abs(rows).sum(axis=1) + np.abs(rhs)
    active = np.zeros(len(rhs), dtype=bool)
    active[np.argsort(closeness)[:_FIRST_ROWS]] = True
    for _ in range(_MAX_ROUNDS):
        found = linprog(objective, A_ub=-rows[active], b_ub=-rhs[active], bounds=bounds, method="highs")
        if found.status != 0:
            raise SolverError(f"an identified-set LP failed ({found.message})", code="identified_set_failed")
        slack = rows @ found.x - rhs
        violated = np.flatnonzero((slack < -1e-9 * (1 + np.abs(rhs))) & ~active)
        if len(violated) == 0:
            return np.asarray(found.x)
        active[violated[np.argsort(slack[violated])[:_ROWS_A_ROUND]]] = True
    raise SolverError("an identified-set LP did not settle", code="identified_set_failed")


def _ordered(world: ReachWorld, values: dict) -> dict:
    """`values` by symbol in the world's order."""
    return {symbol: values[symbol] for symbol in world.symbols}
