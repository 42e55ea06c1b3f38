"""The likelihood of a model of people: the soft fixed point, the recorded-action policy, and the exact gradient.

A person chooses a *direction* sharply and a *level* loosely (a hold is timed by a hand, not picked
from a menu) and now and then lapses. The paper's maxent expert (`maxent.py`) is soft-optimal over
(direction, level) with one temperature for both, and its soft backup runs on after the episode has
ended; on person-like play that puts the goal below zero (docs/people.md). This model adds three
parts, each a parameter estimated with the rewards, nested so that maxent's expert is its special case:

===========  ==========  ===================================================================
part         parameter   what it says
===========  ==========  ===================================================================
end          ``ends``    the soft backup stops at the episode's end: a terminal cell is worth
                         its R_S, the exit 0, with no entropy bonus after the end (a person
                         gets nothing after the goal); without it every state gets the soft
                         backup, as maxent's
hand         sigma       the player intends level c* and the hand realises c with
                         K(c | c*) ~ exp(-(c - c* - b)^2 / (2 sigma^2)) on 1..L, b the hand's
                         bias (0, or known with sigma from a study's calibration trials,
                         `irl_core.irl.people.hand`: then neither is searched); the move's slip
                         and cost are the realised level's, and the player plans for the hand:
                         Q_I(s, d, c*) = sum_c K(c | c*) Q(s, d, c)
lapse        epsilon     with probability epsilon the direction is uniformly random, the level
                         the player's own (lapses are not planned for)
choice       beta        pi_I(d, c* | s) = exp(beta (Q_I(s, d, c*) - V(s)))
===========  ==========  ===================================================================

with V(s) = (1/beta) log sum_j exp(beta Q_I(s, j)) at acting states and
Q(s, a) = R(s, a) + gamma sum_s' P(s' | s, a) V(s'). The recorded action's probability is

    pi_O = (1 - epsilon) q + epsilon Lq,      q(s, d, c) = sum_c* pi_I(s, d, c*) K(c | c*),

where (Lq)(s, d, c) = (1/4) sum_d' q(s, d', c), and the fit maximises LL = sum N(s, a) log pi_O(a | s).

Gradient (exact). As in maxent, beta Q is the beta = 1 Q of the reward beta R, so everything is
computed at beta 1 for R1 = beta R and LL(R, beta) = LL_1(beta R). With W = N / pi_O,
U = (1 - eps) W + eps L W (= dLL/dq), Z = U K^T (= dLL/dpi_I), g = pi_I (Z - <pi_I, Z>) (= dLL/dQ_I)
and D = g K (dLL/dQ with V held), the fixed point's derivative is dV = (I - gamma P^q)^-1 (q . dR + h),
h the change of the soft backup with Q held, so with y = (I - gamma P^q)^-T gamma P^T D:

    dLL/dR1(s, a) = D(s, a) + y(s) q(s, a),     dLL/dR_S = beta sum_a dLL/dR1,
    dLL/dlog beta = sum dLL/dR1 * R1,           dLL/depsilon = sum W (Lq - q),
    dLL/dK = pi_I^T U + g^T Q + (y pi_I)^T Q    (summed over acting states and directions).

`tests/irl/test_people.py` checks every one against central differences, and the special case
(no hand, no lapse, the backup running on) against `maxent.log_likelihood`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from irl_core.irl.choices import Player, PlayerModel
from irl_core.irl.maxent import (
    DENSE_STATES,
    LOG_BETA_BOUNDS,
    Factors,
    expected_next,
    policy_system,
    pulled_back,
    solve_and_factor,
    solve_system,
)
from irl_core.irl.result import SolverError
from irl_core.support.stopping import stop_if_asked
from irl_core.worlds.mdp import MDP
from irl_core.worlds.moves import PolicySystem

# The hand's noise, sigma in levels: at the lower end the kernel is the identity to double precision
# (exp(-1 / (2 * 0.05^2)) = 1e-87), so "no hand noise" is inside the search range.
SIGMA_BOUNDS = (0.05, 20.0)
LAPSE_BOUNDS = (1e-4, 0.5)
START_SIGMA = 1.0
START_LAPSE = 0.02
SOFT_TOLERANCE = 1e-12
SOFT_MAX_ITER = 200
# exp(-log pi_O) of a recorded action is capped here: only a line search's wildest trial point gets
# near it, and there a finite gradient lets L-BFGS-B step back.
MAX_LOG_RATIO = 600.0


# A model of people keeps the intended choice soft: beta at most this (per unit of reward; a level costs 1).
# Data from a player whose intended choice is deterministic (the hand and the lapses making all the noise)
# would drive beta up without end, where the likelihood goes flat in the rewards and the optimiser's start
# decides them; at this cap an intended action worth a third of a level's cost less is still 30 times less
# likely (bench/bench_people.py measures the answers).
MAX_PERSON_BETA = 10.0


def beta_bounds(model: PlayerModel) -> tuple[float, float]:
    """log beta's search range: maxent's, or for a model of people one that keeps the intended choice soft."""
    if not model.hand:
        return LOG_BETA_BOUNDS
    return (LOG_BETA_BOUNDS[0], float(np.log(MAX_PERSON_BETA)))


IDENTITY: dict[int, np.ndarray] = {}  # the kernel without noise, one per level count (compared by identity)


def level_kernel(levels: int, sigma: float, bias: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """K (L, L), K[c* - 1, c - 1] = P(realised c | intended c*), and dK/dlog sigma (L, L); the hand's
    `bias` (levels) shifts every row's centre to c* + bias.

    sigma 0 is the identity (no hand noise)."""
    if sigma <= 0:
        identity = IDENTITY.setdefault(levels, np.eye(levels))
        return identity, np.zeros((levels, levels))
    offset = np.arange(levels)[None, :] - np.arange(levels)[:, None] - bias
    a = offset.astype(float) ** 2 / sigma**2  # -2 dlog w / dlog sigma ... see below
    log_w = -0.5 * a
    log_w -= log_w.max(axis=1, keepdims=True)
    w = np.exp(log_w)
    K = w / w.sum(axis=1, keepdims=True)
    # dlog w / dlog sigma = a, so dK / dlog sigma = K (a - sum_c K a).
    return K, K * (a - (K * a).sum(axis=1, keepdims=True))


def _times(X: np.ndarray, M: np.ndarray) -> np.ndarray:
    """X (..., n) with its last axis grouped by level (n a multiple of L) times M (L, L), one level block at a
    time, as one matrix product: numpy's stacked product of (4, L) blocks is 2.5x slower at 561 states."""
    L = M.shape[0]
    return (X.reshape(-1, L) @ M).reshape(X.shape)


@dataclass(frozen=True)
class PlayerPlan:
    """The model's fixed point for one reward: V (S,) and, at acting states, the intended policy
    pi_I (S, A), the policy the values follow (`backup`: q or pi_I), the realised policy q (S, A) and the
    recorded-action policy pi_O (S, A) with its log; rows of states where nobody acts are uniform."""

    V: np.ndarray
    Q: np.ndarray
    intended: np.ndarray
    backup: np.ndarray
    realised: np.ndarray
    observed: np.ndarray
    log_observed: np.ndarray
    iterations: int



def _forward(mdp: MDP, R1: np.ndarray, K: np.ndarray, *, ends: bool, lapse: float, plans: bool,
             V0: np.ndarray | None) -> tuple[PlayerPlan, np.ndarray | PolicySystem]:
    """Soft policy iteration over intended actions (beta 1), then the recorded-action policy. A player who
    `plans` for the hand values an intended action by the realised ones (Q_I = K Q, the values following
    q); one who does not values it as if it were realised (Q_I = Q, the values following pi_I)."""
    S, A, L = mdp.n_states, mdp.n_actions, mdp.levels
    acting = mdp.nonterminal
    uniform = np.full(A, 1.0 / A)
    end_entropy = 0.0 if ends else float(np.log(A))
    V = np.zeros(S) if V0 is None else np.asarray(V0, dtype=float).copy()

    def improve(V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        Q = R1 + mdp.gamma * expected_next(mdp, V)
        QI = _times(Q, K.T) if plans else Q
        top = QI.max(axis=1, keepdims=True)
        shifted = QI - top
        log_totals = np.log(np.exp(shifted).sum(axis=1, keepdims=True))
        log_pi = shifted - log_totals
        pi = np.exp(log_pi)
        q = _times(pi, K) if plans else pi.copy()
        q[~acting] = uniform
        return Q, pi, log_pi, q, (top + log_totals)[:, 0]

    Q, pi, log_pi, q, soft_max = improve(V)
    # B007 is wrong here: the plan records the last `iteration`, after the loop.
    for iteration in range(1, SOFT_MAX_ITER + 1):  # noqa: B007
        stop_if_asked()
        entropy = np.where(acting, -(pi * log_pi).sum(axis=1), end_entropy)
        system = policy_system(mdp, q)
        V = solve_system(system, (q * R1).sum(axis=1) + entropy)
        Q, pi, log_pi, q, soft_max = improve(V)
        residual = float(np.abs(soft_max - V)[acting].max()) if acting.any() else 0.0
        if residual <= SOFT_TOLERANCE * max(1.0, float(np.abs(V).max())):
            break
    else:
        raise SolverError(
            f"the player model's soft Bellman equations did not converge in {SOFT_MAX_ITER} solves; "
            "the rewards may be too large for this beta: try a smaller rmax"
        )
    # The gradient's system is the final policy's: the last one solved differs from it at first order in
    # the policy, though the residual, which is second order, is already negligible.
    system = policy_system(mdp, q)
    log_q = _log_realised(pi.reshape(S, 4, L), log_pi.reshape(S, 4, L), K)
    if lapse > 0:
        log_level = _log_sum_of_directions(log_q) - np.log(4.0)  # log (Lq)
        log_observed = np.logaddexp(np.log1p(-lapse) + log_q, np.log(lapse) + log_level)
    else:
        log_observed = log_q
    log_observed = log_observed.reshape(S, A)
    log_observed[~acting] = np.log(uniform)
    realised = q if plans else _times(pi, K)
    realised[~acting] = uniform
    plan = PlayerPlan(V=V, Q=Q, intended=pi, backup=q, realised=realised, observed=np.exp(log_observed),
                      log_observed=log_observed, iterations=iteration)
    return plan, system


def _sum_of_directions(x: np.ndarray) -> np.ndarray:
    """(S, 1, L) sum_d x(s, d, c) for x (S, 4, L): x.sum(axis=1) written out (the same sums in the same order, in
    a third of the time)."""
    return (x[:, 0] + x[:, 1] + x[:, 2] + x[:, 3])[:, None, :]


def _log_sum_of_directions(log_x: np.ndarray) -> np.ndarray:
    """(S, 1, L) log sum_d x(s, d, c) for log x (S, 4, L): np.logaddexp.reduce over the directions, written out
    (the same sums in the same order; numpy's reduce over a middle axis takes 1.5x as long)."""
    total = np.logaddexp(log_x[:, 0], log_x[:, 1])
    np.logaddexp(total, log_x[:, 2], out=total)
    np.logaddexp(total, log_x[:, 3], out=total)
    return total[:, None, :]


def _log_realised(pi3: np.ndarray, log_pi3: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(S, 4, L) log q = log sum_c* pi_I(d, c*) K(c | c*). Where q underflows (an unlikely level of an
    unlikely direction) those rows are done again in log space."""
    if K is IDENTITY.get(K.shape[0]):
        return log_pi3.copy()
    q = _times(pi3, K)
    with np.errstate(divide="ignore"):
        log_q = np.log(q)
    low = (q < 1e-250).any(axis=2)
    if low.any():
        with np.errstate(divide="ignore"):
            log_K = np.log(K)
        joint = log_pi3[low][:, :, None] + log_K[None, :, :]
        top = joint.max(axis=1, keepdims=True)
        # A level no intended level can produce (a precise, biased hand's kernel column underflows to 0) has
        # log q = -inf, not -inf - (-inf).
        top[np.isneginf(top)] = 0.0
        with np.errstate(divide="ignore"):
            log_q[low] = (top + np.log(np.exp(joint - top).sum(axis=1, keepdims=True)))[:, 0, :]
    return log_q


# Over this many states (where the policy systems are banded) each evaluation of a search starts from the last one's
# values moved to first order (`WarmStart`): walled-24's people fit 4.6-5.2 s to 4.1-4.5 s. Smaller worlds start from the last
# values as they are, which keeps the answers bench_people measured on them: the step moves L-BFGS-B's path at
# the level of its tolerance, and on `walls` 5 of 60 runs then stopped elsewhere, 2 at another model's optimum of
# near-equal likelihood (docs/benchmarks.md).
WARM_STEP_STATES = DENSE_STATES


@dataclass(frozen=True)
class WarmStart:
    """Where the next evaluation's soft values start: this one's V (S,) for rewards R1 (S, A) (beta 1), moved to first
    order in the rewards' change. With the values following the backup policy q, dV = (I - gamma P^q)^-1 sum_a q dR1,
    solved with the factors the gradient left of the transposed system (two triangular solves): soft policy iteration
    then starts a Newton step nearer and needs about one solve fewer per evaluation (on walled-24, each model's own
    fit's points evaluated both ways: 3.2-4.0 solves to 2.2-3.1). The step leaves out the hand's kernel: with it,
    person's and hand's fits needed 2% and 5% fewer solves still, not worth its three more arrays."""

    V: np.ndarray
    R1: np.ndarray
    backup: np.ndarray
    transposed_factors: Factors | None

    def values_for(self, R1: np.ndarray) -> np.ndarray:
        """(S,) the start for rewards R1 (S, A)."""
        if self.transposed_factors is None:
            return self.V
        change = (self.backup * (R1 - self.R1)).sum(axis=1)
        return self.V + self.transposed_factors.solve(change, transposed=True)


@dataclass(frozen=True)
class Likelihood:
    """LL and its gradient: dLL/dR_S (S,), dLL/dlog beta, dLL/dlog sigma, dLL/dlapse, the plan, and (with the
    gradient) the next evaluation's warm start."""

    value: float
    R_S: np.ndarray
    log_beta: float
    log_sigma: float
    lapse: float
    plan: PlayerPlan
    warm: WarmStart | None = None


def log_likelihood(
    mdp: MDP,
    counts: np.ndarray,
    R_S: np.ndarray,
    *,
    model: PlayerModel,
    player: Player,
    V0: np.ndarray | None = None,
    warm: WarmStart | None = None,
    gradient: bool = True,
) -> Likelihood:
    """LL of recorded counts N (S, A) for state rewards R_S (S,) and the player, with its exact gradient
    (zeros when `gradient` is False). V0 (S,): a start for the soft values at beta 1 (beta V); `warm`: a nearby
    evaluation's `Likelihood.warm`, a better one."""
    beta = player.beta
    K, dK = level_kernel(mdp.levels, player.sigma if model.hand else 0.0, player.bias if model.hand else 0.0)
    lapse = player.lapse if model.lapses else 0.0
    R1 = beta * mdp.reward_matrix(R_S)
    if warm is not None:
        V0 = warm.values_for(R1)
    plan, system = _forward(mdp, R1, K, ends=model.ends, lapse=lapse, plans=model.plans, V0=V0)
    acting = mdp.nonterminal
    counts = np.asarray(counts, dtype=float)
    # Only recorded moves count: one the model gives no chance (log -inf) and nobody made adds 0, not 0 x -inf.
    with np.errstate(invalid="ignore"):
        value = float(np.where(counts[acting] > 0, counts[acting] * plan.log_observed[acting], 0.0).sum())
    if not gradient:
        return Likelihood(value, np.zeros(mdp.n_states), 0.0, 0.0, 0.0, plan)
    S, A, L = mdp.n_states, mdp.n_actions, mdp.levels
    W = np.zeros((S, A))
    seen = acting[:, None] & (counts > 0)
    W[seen] = counts[seen] * np.exp(np.minimum(-plan.log_observed[seen], MAX_LOG_RATIO))
    W3 = W.reshape(S, 4, L)
    U3 = (1 - lapse) * W3 + (lapse / 4) * _sum_of_directions(W3) if lapse > 0 else W3
    pi3 = plan.intended.reshape(S, 4, L)
    Z3 = _times(U3, K.T)
    g3 = pi3 * (Z3 - (pi3 * Z3).sum(axis=(1, 2), keepdims=True))
    g3[~acting] = 0.0
    D = _times(g3, K).reshape(S, A) if model.plans else g3.reshape(S, A)
    m = mdp.gamma * pulled_back(mdp, D)
    y, transposed_factors = solve_and_factor(system.T, m)
    G1 = D + y[:, None] * plan.backup
    grad_R_S = beta * G1.sum(axis=1)
    grad_R_S[mdp.exit_state] = 0.0
    grad_log_beta = float((G1 * R1).sum())
    grad_log_sigma = 0.0
    if model.hand and player.sigma > 0:
        Q3 = plan.Q.reshape(S, 4, L)[acting]
        p3, u3, h3 = pi3[acting], U3[acting], g3[acting] + y[acting, None, None] * pi3[acting]
        # Sums over acting states and directions, each as one (L, n) x (n, L) product (einsum's loop is 8x slower).
        dLL_dK = p3.reshape(-1, L).T @ u3.reshape(-1, L)
        if model.plans:
            dLL_dK += h3.reshape(-1, L).T @ Q3.reshape(-1, L)
        grad_log_sigma = float((dLL_dK * dK).sum())
    grad_lapse = 0.0
    if model.lapses:
        q3 = plan.realised.reshape(S, 4, L)
        grad_lapse = float((W3 * (_sum_of_directions(q3) / 4 - q3))[acting].sum())
    warm_start = WarmStart(plan.V, R1, plan.backup, transposed_factors) if mdp.n_states > WARM_STEP_STATES else None
    return Likelihood(value, grad_R_S, grad_log_beta, grad_log_sigma, grad_lapse, plan, warm_start)

