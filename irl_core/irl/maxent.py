"""The paper's baseline: maximum-entropy IRL by maximum likelihood (Kim et al. 2021).

The expert is modelled as soft-optimal, pi(a | s) = exp(beta (Q(s, a) - V(s))) with the soft
Bellman equations

    Q(s, a) = R_S(s) + R_A(a) + gamma sum_s' P(s' | s, a) V(s'),
    V(s)    = (1/beta) log sum_a exp(beta Q(s, a))      (in every state, as planning.soft_value_iteration),

in the world's own transitions and with the known action cost (docs/fitting.md). The fit
maximises the log likelihood of the demonstrated actions,

    LL(R_S) = sum_{s, a} N(s, a) log pi(a | s) = beta sum_{s, a} N(s, a) (Q(s, a) - V(s)),

over |R_S| <= rmax with L-BFGS-B. Its gradient goes through the soft Bellman fixed point:
dV = (I - gamma P^pi)^-1 dR (the soft maximum's derivative is pi itself), so with n(s) the
visits and m = gamma sum_{s, a} N(s, a) P(. | s, a) the discounted successors of the
demonstrations,

    dLL/dR_S = beta [n + (m - n)^T (I - gamma P^pi)^-1]:

the empirical visits minus the model's expected discounted visitation started from the
demonstrations, one transposed sparse solve per evaluation.

The soft Bellman fixed point itself is found by soft policy iteration (Newton's method on
the soft Bellman equation): evaluate the current soft-greedy policy exactly with one sparse
solve, (I - gamma P^pi) V = R^pi + H^pi / beta, then take pi = softmax(beta Q). It converges
in a handful of solves from the previous evaluation's V, where value iteration would take
hundreds of sweeps at gamma = 0.95.

With actions that are never demonstrated because they are very bad (stepping off the cliff)
the likelihood keeps rising, ever more slowly, as the reward of what they lead to falls: the
data say "bad", not "how bad". L-BFGS-B stops where the gradient has become negligible,
which is how the paper's baseline underestimates the cliff by an order of magnitude.

`--beta auto` estimates beta with R_S. The soft Bellman equations scale: beta Q is the
soft-optimal Q (with beta 1) of the reward beta R, so LL(R_S, beta) = LL_1(beta R) and, with
G(s, a) = dLL_1/dR(s, a) = N(s, a) + y(s) pi(s, a) (y = (I - gamma P^pi)^-T (m - n) as above),

    dLL/dR_S(s) = beta sum_a G(s, a),        dLL/d log beta = sum_{s, a} G(s, a) beta R(s, a).

The fit runs over (theta, log beta). With carefulness levels the known action costs R_A fix
the reward's scale, so beta is identified. With one level every action costs the same: that
constant step cost can be traded against the (unknown) terminal rewards, and on `mud-simple`
the likelihood is the same, to 1e-15, at scales five times apart: beta is not identified
(`identification`).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg.lapack import dgbsv, dgbtrs, dgesv
from scipy.optimize import minimize
from threadpoolctl import ThreadpoolController

from irl_core.irl.qmap import Unknowns
from irl_core.irl.result import SolverError
from irl_core.support.stopping import stop_if_asked
from irl_core.worlds.mdp import MDP
from irl_core.worlds.moves import PolicySystem, moves_of

SOFT_TOLERANCE = 1e-13
SOFT_MAX_ITER = 200
# L-BFGS-B stops when the projected gradient of the mean log likelihood is below this ...
GRADIENT_TOLERANCE = 1e-10
# ... or when an iteration improves it by less than this (relative).
VALUE_TOLERANCE = 1e-15
MAX_ITER = 2000
# --beta auto searches log beta within these bounds; an estimate at either is not identified.
LOG_BETA_BOUNDS = (float(np.log(1e-4)), float(np.log(1e3)))


@dataclass(frozen=True)
class SoftPlan:
    """The soft Bellman fixed point: V (S,), Q (S, A), pi (S, A), log pi (S, A), solves used."""

    V: np.ndarray
    Q: np.ndarray
    policy: np.ndarray
    iterations: int
    log_policy: np.ndarray


def soft_bellman(
    mdp: MDP,
    R_S: np.ndarray,
    *,
    beta: float,
    V0: np.ndarray | None = None,
    tol: float = SOFT_TOLERANCE,
    max_iter: int = SOFT_MAX_ITER,
) -> SoftPlan:
    """Soft-optimal V, Q and pi for state rewards R_S (S,) by soft policy iteration.

    Raises `SolverError` if the Bellman residual max|T(V) - V| is not below tol * max(1, |V|) after
    max_iter solves, `Stopped` once the fit's stop check says so (`stopping.stop_when`).
    """
    return _soft_bellman(mdp, mdp.reward_matrix(R_S), beta=beta, V0=V0, tol=tol, max_iter=max_iter)


def _soft_bellman(mdp: MDP, R: np.ndarray, *, beta: float, V0: np.ndarray | None, tol: float = SOFT_TOLERANCE,
                  max_iter: int = SOFT_MAX_ITER) -> SoftPlan:
    """`soft_bellman` for the reward matrix R (S, A).

    Before each solve it asks the fit's stop check (`stopping.stop_if_asked`), so a fit no longer
    wanted stops within one solve, not at the end of L-BFGS-B (36 s on a 64x64 world, minutes
    with beta estimated).

    Each solve's V is checked by its Bellman residual, max|T(V) - V| with T the soft Bellman
    operator, which the next step's Q and pi give for free; V is then within residual / (1 - gamma)
    of the fixed point. (Checking the change between two solves instead costs one more solve.)
    """
    V = np.zeros(mdp.n_states) if V0 is None else np.asarray(V0, dtype=float)
    Q = R + mdp.gamma * expected_next(mdp, V)
    pi, log_pi, _ = _soft_policy(beta * Q)
    for iteration in range(1, max_iter + 1):
        stop_if_asked()
        V = solve_system(policy_system(mdp, pi), (pi * R).sum(axis=1) - (pi * log_pi).sum(axis=1) / beta)
        Q = R + mdp.gamma * expected_next(mdp, V)
        pi, log_pi, soft_max = _soft_policy(beta * Q)
        residual = float(np.abs(soft_max / beta - V).max())
        if residual <= tol * max(1.0, float(np.abs(V).max())):
            return SoftPlan(V=V, Q=Q, policy=pi, iterations=iteration, log_policy=log_pi)
    raise SolverError(
        f"maxent's soft Bellman equations did not converge in {max_iter} solves (beta {beta:.3g}); "
        "the rewards may be too large for this beta: try a smaller {rmax} or another {beta}",
        code="soft_bellman_diverged",
    )


def _soft_policy(scores: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """softmax, log softmax and logsumexp of scores (S, A) along the actions ((S, A), (S, A), (S,);
    scipy's softmax and logsumexp without their per-call checks, which cost more than the
    arithmetic on a world this size)."""
    top = scores.max(axis=1, keepdims=True)
    shifted = scores - top
    exponentials = np.exp(shifted)
    totals = exponentials.sum(axis=1, keepdims=True)
    log_totals = np.log(totals)
    return exponentials / totals, shifted - log_totals, (top + log_totals)[:, 0]


def log_likelihood(
    mdp: MDP, counts: np.ndarray, R_S: np.ndarray, *, beta: float, V0: np.ndarray | None = None,
    drive: np.ndarray | None = None,
) -> tuple[float, np.ndarray, SoftPlan]:
    """LL(R_S) and its gradient dLL/dR_S (S,) for demonstrated counts N (S, A) (`drive`:
    `demonstration_drive` of the counts, when the caller keeps it)."""
    ll, G, plan, _ = _likelihood(mdp, counts, R_S, beta=beta, V0=V0, drive=drive)
    grad = beta * G.sum(axis=1)
    grad[mdp.exit_state] = 0.0  # the exit's reward is fixed at 0
    return ll, grad, plan


def log_likelihood_beta(
    mdp: MDP, counts: np.ndarray, R_S: np.ndarray, *, beta: float, V0: np.ndarray | None = None,
    drive: np.ndarray | None = None,
) -> tuple[float, np.ndarray, float, SoftPlan]:
    """LL(R_S, beta), dLL/dR_S (S,) and dLL/d log beta, for demonstrated counts N (S, A)
    (`drive`: `demonstration_drive` of the counts, when the caller keeps it)."""
    ll, G, plan, R = _likelihood(mdp, counts, R_S, beta=beta, V0=V0, drive=drive)
    grad = beta * G.sum(axis=1)
    grad[mdp.exit_state] = 0.0
    return ll, grad, float((G * (beta * R)).sum()), plan


def demonstration_drive(mdp: MDP, counts: np.ndarray) -> np.ndarray:
    """(S,) m - n: the demonstrations' discounted successors minus their visits (see the module's text)."""
    return mdp.gamma * pulled_back(mdp, counts) - counts.sum(axis=1)


def _likelihood(
    mdp: MDP, counts: np.ndarray, R_S: np.ndarray, *, beta: float, V0: np.ndarray | None,
    drive: np.ndarray | None = None,
) -> tuple[float, np.ndarray, SoftPlan, np.ndarray]:
    """LL, G (S, A) = dLL/dR(s, a) at beta 1 for the scaled reward beta R (see the module's text),
    the soft plan and R (S, A)."""
    R = mdp.reward_matrix(R_S)
    plan = _soft_bellman(mdp, R, beta=beta, V0=V0)
    acting = mdp.nonterminal
    ll = float((counts[acting] * plan.log_policy[acting]).sum())
    if drive is None:
        drive = demonstration_drive(mdp, counts)
    y = solve_system(policy_system(mdp, plan.policy).T, drive)
    return ll, counts + y[:, None] * plan.policy, plan, R


# Worlds up to this many states keep P as a dense (S, A, S) array: their expectations and
# policy systems are then one matrix product each and their solves a LAPACK call, instead of
# sparse matrices built and factorised in Python (5x faster on the built-in worlds); larger
# ones stay sparse.
DENSE_STATES = 150
_DENSE_P: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _dense_P(mdp: MDP) -> np.ndarray:
    """(S, A, S) P(s' | s, a), dense."""
    P = _DENSE_P.get(mdp)
    if P is None:
        P = _DENSE_P[mdp] = mdp.P.toarray().reshape(mdp.n_states, mdp.n_actions, mdp.n_states)
    return P


def expected_next(mdp: MDP, V: np.ndarray) -> np.ndarray:
    """(S, A) sum_s' P(s' | s, a) V(s'), as `MDP.expected_next` (dense P in small worlds; the models of
    people share it)."""
    if mdp.n_states > DENSE_STATES:
        return mdp.expected_next(V)
    return _dense_P(mdp) @ V


def pulled_back(mdp: MDP, X: np.ndarray) -> np.ndarray:
    """(S,) sum_{s, a} X(s, a) P(s' | s, a) for X (S, A): X.ravel() @ P (in direction form in large worlds)."""
    if mdp.n_states > DENSE_STATES:
        return moves_of(mdp).pulled_back(X)
    return np.asarray(X, dtype=float).ravel() @ mdp.P


def policy_system(mdp: MDP, pi: np.ndarray) -> np.ndarray | PolicySystem:
    """(S, S) I - gamma P^pi for the policy pi (S, A): dense in small worlds, in large ones the entries of the
    world's fixed sparse pattern (built from its moves in direction form, `irl_core.worlds.moves`: 2x faster
    than from P at 24x24)."""
    S = mdp.n_states
    if S > DENSE_STATES:
        return moves_of(mdp).policy_system(pi, gamma=mdp.gamma)
    system = np.matmul(pi[:, None, :], _dense_P(mdp))[:, 0, :]  # row s: sum_a pi(s, a) P(. | s, a)
    system *= -mdp.gamma
    system[np.diag_indices(S)] += 1.0
    return system


# A sparse system whose nonzeros lie within this many diagonals (below plus above) of the main one is solved
# as a band matrix (LAPACK's dgbsv). A grid world's states are numbered row by row, so a move reaches at most
# one row's width away: the band is about twice the width. Measured against SuperLU on generated worlds, one
# solve: 0.17 ms against 0.68 at 24x24 (band 48), 0.40 against 1.38 at 32x32, 1.70 against 3.24 at 48x48,
# 5.3 against 6.2 at 64x64 (band 128); wider bands go to SuperLU.
MAX_BAND = 128


def solve_system(system: np.ndarray | PolicySystem | sp.spmatrix, b: np.ndarray) -> np.ndarray:
    """x (S,) with system x = b for a `policy_system` (or its transpose): LAPACK when dense or banded, SuperLU
    otherwise."""
    return solve_and_factor(system, b)[0]


@dataclass(frozen=True)
class Factors:
    """The band LU factors LAPACK's `dgbsv` left from solving a system A x = b (`solve_and_factor`), with the
    band's `below` and `above`, to solve A or its transpose again at the cost of two triangular solves."""

    lu: np.ndarray
    pivots: np.ndarray
    below: int
    above: int

    def solve(self, b: np.ndarray, *, transposed: bool = False) -> np.ndarray:
        """x (S,) with A x = b, or A^T x = b when `transposed`."""
        x, info = dgbtrs(self.lu, self.below, self.above, b, self.pivots, trans=int(transposed))
        if info != 0:
            raise SolverError(f"LAPACK could not solve with the policy system's factors (info {info})")
        return x


def solve_and_factor(system: np.ndarray | PolicySystem | sp.spmatrix, b: np.ndarray) -> tuple[np.ndarray, Factors | None]:
    """`solve_system`'s x (S,), and the band factors it leaves to solve with again (None where the system was dense
    or SuperLU solved it)."""
    if isinstance(system, np.ndarray):
        _, _, x, info = dgesv(system, b)
        if info != 0:
            raise SolverError(f"maxent's policy system is singular (LAPACK info {info})")
        return x, None
    if isinstance(system, PolicySystem):
        # The world's pattern knows its band: nothing to look for (a third of a 24x24 world's solve).
        if system.moves.below + system.moves.above > MAX_BAND:
            return spla.spsolve(system.tocsc(), b), None
        below, above, band = system.band()
        return _banded(below, above, band, b)
    if not getattr(system, "has_canonical_format", False):
        system = sp.csc_matrix(system, copy=True)
        system.sum_duplicates()  # each entry once, so that placing them in the band below adds nothing up
    entries = system.tocoo()
    below, above = int((entries.row - entries.col).max()), int((entries.col - entries.row).max())
    if below + above > MAX_BAND:
        return spla.spsolve(system.tocsc(), b), None
    # dgbsv's layout: row (below + above + i - j) of column j holds entry (i, j), with `below` rows on top
    # left free for the factorisation's fill.
    band = np.zeros((2 * below + above + 1, system.shape[1]))
    band[below + above + entries.row - entries.col, entries.col] = entries.data
    return _banded(below, above, band, b)


def _banded(below: int, above: int, band: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, Factors]:
    lu, pivots, x, info = dgbsv(below, above, band, b, overwrite_ab=True)
    if info != 0:
        raise SolverError(f"maxent's policy system is singular (LAPACK info {info})")
    return x, Factors(lu, pivots, below, above)


_BLAS: list[ThreadpoolController] = []


def one_blas_thread():
    """A context in which BLAS runs on one thread. The fits' BLAS calls are tiny: on several
    threads they spend more time waking threads than computing (5x slower on a busy 2-core
    machine). The libraries are looked up once per process (each lookup reads the process's
    memory map, which took longer than a resample's refit)."""
    if not _BLAS:
        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1, user_api="blas")


@dataclass(frozen=True)
class MaxEntSolution:
    """theta (k,), beta (given or estimated), the soft V (S,) there, the mean log likelihood,
    and L-BFGS-B's report."""

    theta: np.ndarray
    beta: float
    V: np.ndarray
    mean_log_likelihood: float
    converged: bool
    iterations: int
    message: str

    @property
    def beta_at_bound(self) -> bool:
        """Whether an estimated beta stopped at the end of its search range."""
        return min(abs(np.log(self.beta) - end) for end in LOG_BETA_BOUNDS) < 1e-6


def fit_maxent(
    mdp: MDP,
    unknowns: Unknowns,
    counts: np.ndarray,
    *,
    beta: float | str,
    rmax: float,
    start: tuple[np.ndarray, float] | None = None,
    start_V: np.ndarray | None = None,
    scale: np.ndarray | None = None,
    gradient_tolerance: float = GRADIENT_TOLERANCE,
    value_tolerance: float = VALUE_TOLERANCE,
) -> MaxEntSolution:
    """Maximise the mean log likelihood over the unknowns, |theta| <= rmax (and log beta if
    `beta` is ``"auto"``), from `start` = (theta, beta) or from theta = 0, beta = 1, and
    the soft Bellman iteration from `start_V` (S,).

    `scale` (p,) are the variables' natural sizes (`curvature_scale`): the search runs over
    z / scale, which L-BFGS-B crosses in a few steps where the raw variables (rewards in
    hundreds, log beta near 1) take dozens. The gradient tolerance then applies to the
    scaled variables.

    Raises `Stopped` within one soft Bellman solve once the fit's stop check says so."""
    counts = np.asarray(counts, dtype=float)
    total = counts.sum()
    if total <= 0:
        raise ValueError("maxent needs at least one demonstrated step")
    estimate = beta == "auto"
    theta0, beta0 = start if start is not None else (np.zeros(unknowns.k), 1.0 if estimate else float(beta))
    if unknowns.k == 0 and not estimate:
        ll, _, plan = log_likelihood(mdp, counts, unknowns.fixed, beta=float(beta))
        return MaxEntSolution(np.zeros(0), float(beta), plan.V, ll / total, True, 0, "no unknowns")
    basis_T = unknowns.basis.T.tocsr()  # (k, S), transposed once, not at every evaluation
    warm = {"V": start_V}
    drive = demonstration_drive(mdp, counts)

    def negative(z: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = _negative(z * unit)
        return value, gradient * unit

    def _negative(z: np.ndarray) -> tuple[float, np.ndarray]:
        theta = z[: unknowns.k]
        R_S = unknowns.state_rewards(theta)
        if estimate:
            ll, grad, grad_log_beta, plan = log_likelihood_beta(mdp, counts, R_S, beta=float(np.exp(z[-1])),
                                                                V0=warm["V"], drive=drive)
            gradient = np.append(basis_T @ grad, grad_log_beta)
        else:
            ll, grad, plan = log_likelihood(mdp, counts, R_S, beta=float(beta), V0=warm["V"], drive=drive)
            gradient = basis_T @ grad
        warm["V"] = plan.V
        return -ll / total, -gradient / total

    z0 = np.asarray(theta0, dtype=float)
    bounds = [(-rmax, rmax)] * unknowns.k
    if estimate:
        z0 = np.append(z0, np.clip(np.log(beta0), *LOG_BETA_BOUNDS))
        bounds.append(LOG_BETA_BOUNDS)
    unit = np.ones(z0.size) if scale is None else np.asarray(scale, dtype=float)
    z0 = z0 / unit
    bounds = [(low / u, high / u) for (low, high), u in zip(bounds, unit)]
    with one_blas_thread():
        result = minimize(
            negative,
            z0,
            jac=True,
            method="L-BFGS-B",
            bounds=bounds,
            options={"maxiter": MAX_ITER, "gtol": gradient_tolerance, "ftol": value_tolerance},
        )
    z = result.x * unit
    theta = np.asarray(z[: unknowns.k], dtype=float)
    fitted_beta = float(np.exp(z[-1])) if estimate else float(beta)
    plan = soft_bellman(mdp, unknowns.state_rewards(theta), beta=fitted_beta, V0=warm["V"])
    return MaxEntSolution(
        theta=theta,
        beta=fitted_beta,
        V=plan.V,
        mean_log_likelihood=float(-result.fun),
        converged=bool(result.success),
        iterations=int(result.nit),
        message=str(result.message),
    )


def curvature_scale(
    mdp: MDP, unknowns: Unknowns, counts: np.ndarray, *, theta: np.ndarray, beta: float, estimate: bool, rmax: float
) -> np.ndarray:
    """(p,) 1 / sqrt of the mean negative log likelihood's curvature along each variable at
    (theta, log beta), from central differences of the exact gradient; capped at rmax where
    the likelihood is (nearly) flat, e.g. for a cliff nobody steps into."""
    counts = np.asarray(counts, dtype=float)
    total = counts.sum()
    basis = unknowns.basis.tocsc()
    z = np.append(theta, np.log(beta)) if estimate else np.asarray(theta, dtype=float)

    def gradient(point: np.ndarray) -> np.ndarray:
        R_S = unknowns.state_rewards(point[: unknowns.k])
        if estimate:
            _, grad, grad_log_beta, _ = log_likelihood_beta(mdp, counts, R_S, beta=float(np.exp(point[-1])))
            return -np.append(basis.T @ grad, grad_log_beta) / total
        _, grad, _ = log_likelihood(mdp, counts, R_S, beta=beta)
        return -(basis.T @ grad) / total

    curvature = np.empty(z.size)
    with one_blas_thread():
        for j in range(z.size):
            h = 1e-4 * max(1.0, abs(z[j]))
            step = np.zeros(z.size)
            step[j] = h
            curvature[j] = (gradient(z + step)[j] - gradient(z - step)[j]) / (2 * h)
    scale = 1.0 / np.sqrt(np.maximum(curvature, 1.0 / rmax**2))
    return np.minimum(scale, rmax)
