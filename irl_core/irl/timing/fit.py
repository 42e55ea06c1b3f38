"""The timing fit: a time world's rewards, slip curve and player, from exact holds (docs/timing.md).

On a time world a step records the direction chosen, the exact hold d and whether the move slipped. The
model of a player (``timing`` in docs/timing.md):

- the player plans over continuous holds. Moving in direction d from s with a hold of h ms gives
  Q(s, d, h) = R_S(s) - c h / 1000 + gamma [(1 - p(h)) V_a + p(h) V_o], V_a the value of the cell ahead,
  V_o the mean of the other three, p the slip curve p(h) = p_inf + (p0 - p_inf) exp(-h / tau). Q is concave
  in h where V_a > V_o, and its best hold is closed-form:
  h*(s, d) = tau ln(gamma (p0 - p_inf) (V_a - V_o) 1000 / (c tau)), clipped to [SHORTEST_HOLD_MS, max_hold_ms];
  V(s) = max_d Q(s, d, h*(s, d)) is found by value iteration over that rule;
- with probability 1 - lapse the player picks d by softmax(beta Q(s, ., h*)) and holds
  h*(s, d) exp(N(0, sigma^2)) (timing noise that grows with the hold); with probability lapse, any direction
  and any hold (log-uniform over the world's range);
- each move slips with p(d) at the exact hold: a Bernoulli outcome.

All of it is one likelihood, maximised over the rewards theta (k,), the curve (p0, p_inf, tau_ms) and the
player (beta, sigma, lapse) together; the rewards are identified by where the holds sit (the care a player
pays shows what it fears), the curve by the slips and by the holds. Intervals are Wald intervals with a
sandwich covariance clustered by participant (by episode without participants), which stays honest when the
player is not exactly this model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.stats import norm

from irl_core.irl.qmap import Unknowns
from irl_core.irl.timing.slip_curve import SlipCurve
from irl_core.worlds.mdp import MDP
from irl_core.worlds.world import SHORTEST_HOLD_MS

# The player's parameters live on these log scales while searched (beta per point of reward, sigma of log hold).
LOG_BETA = (np.log(1e-3), np.log(1e3))
LOG_SIGMA = (np.log(0.01), np.log(3.0))
LOGIT_LAPSE = (-9.0, 3.0)
LOG_TAU_FACTOR = (np.log(1e-3), np.log(100.0))  # tau_ms as a multiple of max_hold_ms
_VALUE_TOL = 1e-12
_MAX_SWEEPS = 20_000


@dataclass(frozen=True)
class TimingPlan:
    """The best holds and values for rewards R_S (S,): V (S,), Q (S, 4) at each direction's best hold,
    hold (S, 4) that hold in ms (0 where the player does not act), and whether value iteration converged."""

    V: np.ndarray
    Q: np.ndarray
    hold: np.ndarray
    converged: bool


def timing_plan(mdp: MDP, R_S: np.ndarray, *, p0: float, p_inf: float, tau_ms: float,
                cost_per_second: float, V0: np.ndarray | None = None) -> TimingPlan:
    """Value iteration over directions with each direction's closed-form best hold (module docstring), from
    the values `V0` (S,) when given (a nearby fit's: the search's next point converges in a few sweeps)."""
    world, gamma = mdp.world, mdp.gamma
    acting = mdp.nonterminal
    neighbours = mdp.neighbour  # (S, 4)
    V = np.where(acting, 0.0 if V0 is None else V0, np.asarray(R_S, dtype=float))
    V[mdp.exit_state] = 0.0
    drop = max(p0 - p_inf, 0.0)
    scale = max(float(np.abs(R_S).max()), 1.0)
    converged = False
    for _ in range(_MAX_SWEEPS):
        Q, hold = _backup(V, R_S, neighbours, gamma=gamma, drop=drop, p_inf=p_inf, tau=tau_ms,
                          cost=cost_per_second, longest=world.max_hold_ms)
        new = np.where(acting, Q.max(axis=1), V)
        change = float(np.abs(new - V).max())
        V = new
        if change < _VALUE_TOL * scale:
            converged = True
            break
    Q, hold = _backup(V, R_S, neighbours, gamma=gamma, drop=drop, p_inf=p_inf, tau=tau_ms,
                      cost=cost_per_second, longest=world.max_hold_ms)
    return TimingPlan(V=V, Q=Q, hold=np.where(acting[:, None], hold, 0.0), converged=converged)


def _backup(V: np.ndarray, R_S: np.ndarray, neighbours: np.ndarray, *, gamma: float, drop: float, p_inf: float,
            tau: float, cost: float, longest: float) -> tuple[np.ndarray, np.ndarray]:
    """(S, 4) Q at each direction's best hold, and that hold (ms)."""
    ahead = V[neighbours]  # (S, 4)
    others = (ahead.sum(axis=1, keepdims=True) - ahead) / 3.0
    gain = ahead - others
    if cost > 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            best = tau * np.log(gamma * drop * np.maximum(gain, 0.0) * 1000.0 / (cost * tau))
        hold = np.clip(np.nan_to_num(best, nan=SHORTEST_HOLD_MS, neginf=SHORTEST_HOLD_MS), SHORTEST_HOLD_MS, longest)
    else:
        hold = np.where(gain > 0, longest, SHORTEST_HOLD_MS)
    slip = p_inf + drop * np.exp(-hold / tau)
    Q = R_S[:, None] - cost * hold / 1000.0 + gamma * ((1 - slip) * ahead + slip * others)
    return Q, hold


@dataclass(frozen=True)
class TimingFit:
    """The timing fit's answer: theta (k,), the curve, the player (beta per point, sigma of log hold, lapse),
    the plan at the answer, the mean log likelihood per step, whether the search converged, and the
    parameters' covariance (p, p) in the search's coordinates with their names (None if it could not be had)."""

    theta: np.ndarray
    curve: SlipCurve
    beta: float
    sigma: float
    lapse: float
    plan: TimingPlan
    mean_log_likelihood: float
    converged: bool
    message: str
    theta_intervals: np.ndarray | None
    interval_route: str = "sandwich"


def fit_timing(mdp: MDP, unknowns: Unknowns, steps: np.ndarray, *, rmax: float, cost_per_second: float,
               groups: np.ndarray | None = None, slip_known: bool = False, confidence: float = 0.95,
               start_theta: np.ndarray | None = None, start_curve: SlipCurve | None = None) -> TimingFit:
    """Maximise the timing model's likelihood of `steps` (m, 5) = (state, direction, hold_ms, slipped, episode row).

    Args:
        groups: (E,) the participant of each episode row, for the clustered covariance (None: each episode).
        slip_known: hold the world's curve fixed instead of estimating it.
        start_theta: (k,) where the rewards' search starts (e.g. the bins' people fit), else -rmax / 10.
        start_curve: where the curve's search starts (e.g. the slips' own fit), else p0 0.5, p_inf 0.5 p0 / (1 + e^3),
            tau a tenth of max_hold_ms; its intervals stand in for a curve parameter the joint likelihood is flat along.
    """
    world = mdp.world
    k = unknowns.k
    s = steps[:, 0].astype(np.int64)
    d = steps[:, 1].astype(np.int64)
    hold = np.clip(steps[:, 2], 1.0, world.max_hold_ms)
    slipped = steps[:, 3]
    episode = steps[:, 4].astype(np.int64)
    log_hold = np.log(hold)
    log_range = np.log(world.max_hold_ms / SHORTEST_HOLD_MS)
    anything = -log_hold - np.log(log_range) - np.log(4.0)  # a lapse: any direction, any hold, log-uniform
    basis, fixed = unknowns.basis, unknowns.fixed

    def unpack(z: np.ndarray) -> tuple[np.ndarray, float, float, float, float, float, float]:
        theta = z[:k]
        beta, sigma, lapse = np.exp(z[k]), np.exp(z[k + 1]), 1 / (1 + np.exp(-z[k + 2]))
        if slip_known:
            return theta, beta, sigma, lapse, world.p0, world.p_inf, world.tau_ms
        p0 = 1 / (1 + np.exp(-z[k + 3]))
        return theta, beta, sigma, lapse, p0, p0 * (1 / (1 + np.exp(-z[k + 4]))), world.max_hold_ms * np.exp(z[k + 5])

    last_V: list[np.ndarray] = []  # the values of the last point evaluated, where the next one's sweeps start

    def per_step(z: np.ndarray) -> np.ndarray:
        theta, beta, sigma, lapse, p0, p_inf, tau = unpack(z)
        R_S = basis @ theta + fixed
        plan = timing_plan(mdp, R_S, p0=p0, p_inf=p_inf, tau_ms=tau, cost_per_second=cost_per_second,
                           V0=last_V[0] if last_V else None)
        last_V[:] = [plan.V]
        q = beta * plan.Q[s]  # (m, 4)
        q -= q.max(axis=1, keepdims=True)
        log_direction = q[np.arange(s.size), d] - np.log(np.exp(q).sum(axis=1))
        aim = np.log(np.maximum(plan.hold[s, d], SHORTEST_HOLD_MS))
        log_timing = norm.logpdf(log_hold, aim, sigma) - log_hold
        chosen = np.log1p(-lapse) + log_direction + log_timing
        lapsed = np.log(lapse) + anything
        slip = np.clip(p_inf + (p0 - p_inf) * np.exp(-hold / tau), 1e-12, 1 - 1e-12)
        log_slip = slipped * np.log(slip) + (1 - slipped) * np.log1p(-slip)
        return np.logaddexp(chosen, lapsed) + log_slip

    def negative(z: np.ndarray) -> float:
        value = -float(per_step(z).sum()) / s.size
        return value if np.isfinite(value) else 1e6

    theta0 = np.full(k, -rmax / 10) if start_theta is None else np.clip(start_theta, -rmax, rmax)
    player0 = [np.log(1.0 / max(rmax / 100, 1e-9)), np.log(0.3), -2.0]
    curve0 = ([] if slip_known else [0.0, -3.0, np.log(0.1)] if start_curve is None else
              [_logit(start_curve.p0), _logit(start_curve.p_inf / max(start_curve.p0, 1e-9)),
               np.log(start_curve.tau_ms / world.max_hold_ms)])
    bounds = ([(-rmax, rmax)] * k + [LOG_BETA, LOG_SIGMA, LOGIT_LAPSE]
              + ([] if slip_known else [(-9.0, 9.0), (-12.0, 9.0), LOG_TAU_FACTOR]))
    z0 = np.clip(np.array([*theta0, *player0, *curve0]), *np.array(bounds).T)
    # Rewards move in units of rmax / 100, the rest in their own units: one step size suits both.
    unit = np.array([rmax / 100] * k + [1.0] * (z0.size - k))
    scaled = minimize(lambda x: negative(x * unit), z0 / unit, method="L-BFGS-B",
                      bounds=[(lo / u, hi / u) for (lo, hi), u in zip(bounds, unit)], options={"maxiter": 2000, "eps": 1e-6})
    z = scaled.x * unit
    theta, beta, sigma, lapse, p0, p_inf, tau = unpack(z)
    R_S = basis @ theta + fixed
    plan = timing_plan(mdp, R_S, p0=p0, p_inf=p_inf, tau_ms=tau, cost_per_second=cost_per_second)
    # A player or curve parameter run to the end of its range (a choice already deterministic) is held there:
    # the likelihood still climbs past it, so its curvature says nothing. A reward at ±rmax is kept, its
    # interval then reaching the bound.
    lows, highs = np.array(bounds).T
    held = (np.arange(z.size) >= k) & ((z - lows < 1e-2 * unit) | (highs - z < 1e-2 * unit))
    covariance, route = _sandwich(per_step, z, unit, episode if groups is None else np.asarray(groups)[episode], ~held,
                           rewards=k)
    theta_intervals = None
    curve_interval = None if start_curve is None else start_curve.interval  # the slips' own, failing the joint
    if covariance is not None and not np.all(np.diag(covariance)[:k] > 0):
        covariance, route = None, "none"  # a reward's variance of 0 or less would be an interval of no width
    if covariance is not None:
        half = norm.ppf(0.5 + confidence / 2) * np.sqrt(np.maximum(np.diag(covariance), 0.0))
        # A reward the likelihood is flat along is bounded by rmax alone: its interval reaches the bounds.
        theta_intervals = np.column_stack([np.where(np.isnan(half[:k]), -rmax, theta - half[:k]),
                                           np.where(np.isnan(half[:k]), rmax, theta + half[:k])])
        theta_intervals = np.clip(theta_intervals, -rmax, rmax)
        if not slip_known:
            curve_interval = _curve_interval(z, half, k, world.max_hold_ms,
                                             None if start_curve is None else start_curve.interval)
    curve = (SlipCurve.of_world(world, observations=int(s.size)) if slip_known else
             SlipCurve(float(p0), float(p_inf), float(tau), known=False, observations=int(s.size),
                       interval=curve_interval))
    return TimingFit(theta=np.asarray(theta, dtype=float), curve=curve, beta=float(beta), sigma=float(sigma),
                     lapse=float(lapse), plan=plan, mean_log_likelihood=-float(scaled.fun),
                     converged=bool(scaled.success), message=str(scaled.message), theta_intervals=theta_intervals,
                     interval_route=route)


def _sandwich(per_step, z: np.ndarray, unit: np.ndarray, cluster: np.ndarray, free: np.ndarray, *,
              rewards: int) -> tuple[np.ndarray | None, str]:
    """(p, p) H^-1 J H^-1 at z over the coordinates `free` (p,) (NaN rows and columns for the others and for those
    the likelihood is flat along): H the negative log likelihood's Hessian, J the outer products of each
    cluster's score, both by central differences in steps of `unit` * 1e-3 (a reward at its bound is differenced
    across it: the likelihood is defined there). The first `rewards` coordinates are the rewards; None when H is
    not positive definite even without every other parameter. Returns the covariance and its route: ``sandwich``,
    ``scores`` (the outer product of the scores alone, when the differenced curvature is not positive definite)
    or ``none``."""
    p = z.size
    step = unit * 1e-3
    clusters, index = np.unique(cluster, return_inverse=True)
    scores = np.zeros((clusters.size, p))
    for j in np.flatnonzero(free):
        e = np.zeros(p)
        e[j] = step[j]
        up, down = per_step(z + e), per_step(z - e)
        scores[:, j] = np.bincount(index, weights=(up - down) / (2 * step[j]), minlength=clusters.size)
    hessian = np.zeros((p, p))

    def total(x: np.ndarray) -> float:
        return float(per_step(x).sum())

    centre = total(z)
    for i in np.flatnonzero(free):
        for j in np.flatnonzero(free):
            if j < i:
                continue
            ei, ej = np.zeros(p), np.zeros(p)
            ei[i], ej[j] = step[i], step[j]
            if i == j:
                value = (total(z + ei) - 2 * centre + total(z - ei)) / step[i] ** 2
            else:
                value = (total(z + ei + ej) - total(z + ei - ej) - total(z - ei + ej) + total(z - ei - ej)) / (
                    4 * step[i] * step[j])
            hessian[i, j] = hessian[j, i] = -value
    # A coordinate the likelihood barely bends along (a slip chance at 0, a choice already deterministic) is
    # left out: its Wald interval would mean nothing.
    bend = np.diag(hessian) * unit**2  # in the search's own units, where the parameters are comparable
    keep = free & (bend > 1e-6 * max(float(bend.max()), 1e-300))
    meat = scores.T @ scores
    out = np.full((p, p), np.nan)
    while True:
        inner = np.ix_(keep, keep)
        try:
            np.linalg.cholesky(hessian[inner])
            inverse = np.linalg.inv(hessian[inner])
            sandwich = inverse @ meat[inner] @ inverse
            # The wider of the sandwich and the curvature's own variance: where the scores barely move (a reward the
            # holds do not depend on) the sandwich alone would shrink to nothing, while the curvature still says
            # how little the data pin it.
            np.fill_diagonal(sandwich, np.maximum(np.diag(sandwich), np.diag(inverse)))
            out[inner] = sandwich
            return out, "sandwich"
        except np.linalg.LinAlgError:
            # Not positive definite: leave out the player or curve parameter that bends least, and try again;
            # the rewards are what the intervals are for, so they are never the ones left out.
            spare = np.flatnonzero(keep & (np.arange(p) >= rewards))
            if spare.size == 0:
                break
            keep[spare[np.argmin(bend[spare])]] = False
    # The curvature by differences is not positive definite even over the rewards (the best hold's clip at the
    # shortest hold puts kinks in the likelihood): the scores' own spread stands in for it (the outer-product
    # estimate, right when the model is), still over the participants.
    keep = free & (bend > 1e-6 * max(float(bend.max()), 1e-300))
    inner = np.ix_(keep, keep)
    try:
        out[inner] = np.linalg.inv(meat[inner])
    except np.linalg.LinAlgError:
        return None, "none"
    return out, "scores"


def _curve_interval(z: np.ndarray, half: np.ndarray, k: int, max_hold_ms: float,
                    flat: dict[str, tuple[float, float]] | None) -> dict[str, tuple[float, float]]:
    """The curve's intervals: Wald on the search's coordinates (logit p0, logit p_inf / p0, log tau), mapped back;
    for a coordinate the joint likelihood is flat along (a p_inf at 0), the slips' own profile interval `flat`
    (or the whole range without one)."""
    def logistic(x: float) -> float:
        return float(1 / (1 + np.exp(-x)))

    left_out = np.isnan(half)
    half = np.where(left_out, np.inf, half)
    p0_lo, p0_hi = logistic(z[k + 3] - half[k + 3]), logistic(z[k + 3] + half[k + 3])
    r_lo, r_hi = logistic(z[k + 4] - half[k + 4]), logistic(z[k + 4] + half[k + 4])
    # Clipped to the range searched: beyond it the curve is flat over every hold, as far as anything here says.
    tau_lo, tau_hi = max_hold_ms * np.exp(np.clip([z[k + 5] - half[k + 5], z[k + 5] + half[k + 5]], *LOG_TAU_FACTOR))
    out = {"p0": (float(p0_lo), float(p0_hi)), "p_inf": (float(p0_lo * r_lo), float(p0_hi * r_hi)),
           "tau_ms": (float(tau_lo), float(tau_hi))}
    for name, j in (("p0", k + 3), ("p_inf", k + 4), ("tau_ms", k + 5)):
        if flat is not None and (left_out[j] or (name == "p_inf" and left_out[k + 3])):
            out[name] = flat[name]
    return out


def _logit(p: float) -> float:
    p = min(max(p, 1e-6), 1 - 1e-6)
    return float(np.log(p / (1 - p)))


def timing_policy(mdp: MDP, fitted: TimingFit) -> np.ndarray:
    """(S, A) the fitted player's chance of each (direction, duration bin) in every state: the direction by the
    softmax (or a lapse), the hold's log-normal mass in each bin (or a lapse's log-uniform mass); what the fit
    check simulates."""
    world = mdp.world
    edges = np.log(np.maximum(np.asarray(world.duration_bins_ms, dtype=float), 1e-300))
    edges[0], edges[-1] = -np.inf, np.inf  # a hold below the first inner edge, or capped at the last
    q = fitted.beta * fitted.plan.Q
    q -= q.max(axis=1, keepdims=True)
    direction = np.exp(q) / np.exp(q).sum(axis=1, keepdims=True)  # (S, 4)
    aim = np.log(np.maximum(fitted.plan.hold, SHORTEST_HOLD_MS))  # (S, 4)
    mass = np.diff(norm.cdf((edges[None, None, :] - aim[..., None]) / fitted.sigma), axis=2)  # (S, 4, L)
    low, high = np.log(SHORTEST_HOLD_MS), np.log(world.max_hold_ms)
    spread = np.diff(np.clip(np.where(np.isfinite(edges), edges, np.where(edges > 0, high, low)), low, high)) / (high - low)
    policy = (1 - fitted.lapse) * direction[..., None] * mass + fitted.lapse / 4 * spread[None, None, :]
    policy = policy.reshape(mdp.n_states, -1)
    policy[~mdp.nonterminal] = 1.0 / policy.shape[1]
    return policy


def timing_chooser(mdp: MDP, fitted: TimingFit) -> Callable[[np.ndarray, np.ndarray, np.random.Generator, np.ndarray],
                                                             tuple[np.ndarray, np.ndarray]]:
    """The fitted player as an `irl_core.players.experts.Chooser` over continuous holds (what the fit check
    replays): the direction by the softmax or a lapse's uniform one, the hold log-normal around h*(s, d) or a
    lapse's log-uniform one; returns (actions, holds), the action's level being the hold's bin + 1."""
    world, levels = mdp.world, mdp.levels
    q = fitted.beta * fitted.plan.Q
    q -= q.max(axis=1, keepdims=True)
    cdf = np.cumsum(np.exp(q) / np.exp(q).sum(axis=1, keepdims=True), axis=1)  # (S, 4)
    aim = np.log(np.maximum(fitted.plan.hold, SHORTEST_HOLD_MS))  # (S, 4)
    low, high = np.log(SHORTEST_HOLD_MS), np.log(world.max_hold_ms)

    def choose(s: np.ndarray, previous: np.ndarray, rng: np.random.Generator,
               episode: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lapsed = rng.random(s.size) < fitted.lapse
        d = np.where(lapsed, rng.integers(4, size=s.size),
                     np.minimum((cdf[s] < rng.random((s.size, 1))).sum(axis=1), 3))
        hold = np.where(lapsed, np.exp(rng.uniform(low, high, s.size)),
                        np.exp(aim[s, d] + fitted.sigma * rng.normal(size=s.size)))
        hold = np.minimum(hold, world.max_hold_ms)
        return d * levels + world.bin_of(hold), hold

    return choose
