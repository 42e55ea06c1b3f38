"""People as they play: a player model for human play, fitted with the rewards by maximum likelihood.

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
                         K(c | c*) ~ exp(-(c - c*)^2 / (2 sigma^2)) on 1..L; the move's slip
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

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.optimize import minimize

from irl_core.irl.maxent import LOG_BETA_BOUNDS, _expected_next, _solve, one_blas_thread, policy_system
from irl_core.irl.player_models import CANDIDATES, PLAYER_MODELS, Player, PlayerModel, player_model
from irl_core.irl.qmap import Unknowns
from irl_core.irl.result import SolverError
from irl_core.support.stopping import stop_if_asked
from irl_core.worlds.mdp import MDP

# The hand's noise, sigma in levels: at the lower end the kernel is the identity to double precision
# (exp(-1 / (2 * 0.05^2)) = 1e-87), so "no hand noise" is inside the search range.
SIGMA_BOUNDS = (0.05, 20.0)
LAPSE_BOUNDS = (1e-4, 0.5)
START_SIGMA = 1.0
START_LAPSE = 0.02
SOFT_TOLERANCE = 1e-12
SOFT_MAX_ITER = 200
# L-BFGS-B stops when an iteration improves the mean log likelihood by less than this, relative.
# A reward the data do not pin (a cliff nobody steps into) only walks on along a flat direction past
# this point, so its value is the optimiser's patience, not the data's: the fit reads such rewards as
# one-sided ("at most X", `flat_toward_bound`), bench/bench_people.py measures both speed and answers.
VALUE_TOLERANCE = 1e-10
GRADIENT_TOLERANCE = 1e-7
MAX_ITER = 1000
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


def level_kernel(levels: int, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """K (L, L), K[c* - 1, c - 1] = P(realised c | intended c*), and dK/dlog sigma (L, L).

    sigma 0 is the identity (no hand noise)."""
    if sigma <= 0:
        identity = IDENTITY.setdefault(levels, np.eye(levels))
        return identity, np.zeros((levels, levels))
    offset = np.arange(levels)[None, :] - np.arange(levels)[:, None]
    a = offset.astype(float) ** 2 / sigma**2  # -2 dlog w / dlog sigma ... see below
    log_w = -0.5 * a
    log_w -= log_w.max(axis=1, keepdims=True)
    w = np.exp(log_w)
    K = w / w.sum(axis=1, keepdims=True)
    # dlog w / dlog sigma = a, so dK / dlog sigma = K (a - sum_c K a).
    return K, K * (a - (K * a).sum(axis=1, keepdims=True))


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


@dataclass
class _Work:
    """What the gradient needs from the forward pass (all at beta 1, for R1 = beta R)."""

    R1: np.ndarray
    plan: PlayerPlan
    K: np.ndarray
    dK: np.ndarray
    system: np.ndarray | sp.spmatrix


def _forward(mdp: MDP, R1: np.ndarray, K: np.ndarray, *, ends: bool, lapse: float, plans: bool,
             V0: np.ndarray | None) -> tuple[PlayerPlan, np.ndarray | sp.spmatrix]:
    """Soft policy iteration over intended actions (beta 1), then the recorded-action policy. A player who
    `plans` for the hand values an intended action by the realised ones (Q_I = K Q, the values following
    q); one who does not values it as if it were realised (Q_I = Q, the values following pi_I)."""
    S, A, L = mdp.n_states, mdp.n_actions, mdp.levels
    acting = mdp.nonterminal
    uniform = np.full(A, 1.0 / A)
    end_entropy = 0.0 if ends else float(np.log(A))
    V = np.zeros(S) if V0 is None else np.asarray(V0, dtype=float).copy()

    def improve(V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        Q = R1 + mdp.gamma * _expected_next(mdp, V)
        QI = (Q.reshape(S, 4, L) @ K.T).reshape(S, A) if plans else Q
        top = QI.max(axis=1, keepdims=True)
        shifted = QI - top
        log_totals = np.log(np.exp(shifted).sum(axis=1, keepdims=True))
        log_pi = shifted - log_totals
        pi = np.exp(log_pi)
        q = (pi.reshape(S, 4, L) @ K).reshape(S, A) if plans else pi.copy()
        q[~acting] = uniform
        return Q, pi, log_pi, q, (top + log_totals)[:, 0]

    Q, pi, log_pi, q, soft_max = improve(V)
    # B007 is wrong here: the plan records the last `iteration`, after the loop.
    for iteration in range(1, SOFT_MAX_ITER + 1):  # noqa: B007
        stop_if_asked()
        entropy = np.where(acting, -(pi * log_pi).sum(axis=1), end_entropy)
        system = policy_system(mdp, q)
        V = _solve(system, (q * R1).sum(axis=1) + entropy)
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
        log_level = np.logaddexp.reduce(log_q, axis=1, keepdims=True) - np.log(4.0)  # log (Lq)
        log_observed = np.logaddexp(np.log1p(-lapse) + log_q, np.log(lapse) + log_level)
    else:
        log_observed = log_q
    log_observed = log_observed.reshape(S, A)
    log_observed[~acting] = np.log(uniform)
    realised = q if plans else (pi.reshape(S, 4, L) @ K).reshape(S, A)
    realised[~acting] = uniform
    plan = PlayerPlan(V=V, Q=Q, intended=pi, backup=q, realised=realised, observed=np.exp(log_observed),
                      log_observed=log_observed, iterations=iteration)
    return plan, system


def _log_realised(pi3: np.ndarray, log_pi3: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(S, 4, L) log q = log sum_c* pi_I(d, c*) K(c | c*). Where q underflows (an unlikely level of an
    unlikely direction) those rows are done again in log space."""
    if K is IDENTITY.get(K.shape[0]):
        return log_pi3.copy()
    q = pi3 @ K
    with np.errstate(divide="ignore"):
        log_q = np.log(q)
    low = (q < 1e-250).any(axis=2)
    if low.any():
        with np.errstate(divide="ignore"):
            log_K = np.log(K)
        joint = log_pi3[low][:, :, None] + log_K[None, :, :]
        top = joint.max(axis=1, keepdims=True)
        log_q[low] = (top + np.log(np.exp(joint - top).sum(axis=1, keepdims=True)))[:, 0, :]
    return log_q


@dataclass(frozen=True)
class Likelihood:
    """LL and its gradient: dLL/dR_S (S,), dLL/dlog beta, dLL/dlog sigma, dLL/dlapse, and the plan."""

    value: float
    R_S: np.ndarray
    log_beta: float
    log_sigma: float
    lapse: float
    plan: PlayerPlan


def log_likelihood(
    mdp: MDP,
    counts: np.ndarray,
    R_S: np.ndarray,
    *,
    model: PlayerModel,
    player: Player,
    V0: np.ndarray | None = None,
    gradient: bool = True,
) -> Likelihood:
    """LL of recorded counts N (S, A) for state rewards R_S (S,) and the player, with its exact gradient
    (zeros when `gradient` is False). V0 (S,): a start for the soft values at beta 1 (beta V)."""
    beta = player.beta
    K, dK = level_kernel(mdp.levels, player.sigma if model.hand else 0.0)
    lapse = player.lapse if model.lapses else 0.0
    R1 = beta * mdp.reward_matrix(R_S)
    plan, system = _forward(mdp, R1, K, ends=model.ends, lapse=lapse, plans=model.plans, V0=V0)
    acting = mdp.nonterminal
    counts = np.asarray(counts, dtype=float)
    value = float((counts[acting] * plan.log_observed[acting]).sum())
    if not gradient:
        return Likelihood(value, np.zeros(mdp.n_states), 0.0, 0.0, 0.0, plan)
    S, A, L = mdp.n_states, mdp.n_actions, mdp.levels
    W = np.zeros((S, A))
    seen = acting[:, None] & (counts > 0)
    W[seen] = counts[seen] * np.exp(np.minimum(-plan.log_observed[seen], MAX_LOG_RATIO))
    W3 = W.reshape(S, 4, L)
    U3 = (1 - lapse) * W3 + (lapse / 4) * W3.sum(axis=1, keepdims=True) if lapse > 0 else W3
    pi3 = plan.intended.reshape(S, 4, L)
    Z3 = U3 @ K.T
    g3 = pi3 * (Z3 - (pi3 * Z3).sum(axis=(1, 2), keepdims=True))
    g3[~acting] = 0.0
    D = (g3 @ K).reshape(S, A) if model.plans else g3.reshape(S, A)
    m = mdp.gamma * (D.ravel() @ mdp.P)
    y = _solve(system.T if isinstance(system, np.ndarray) else system.T.tocsc(), m)
    G1 = D + y[:, None] * plan.backup
    grad_R_S = beta * G1.sum(axis=1)
    grad_R_S[mdp.exit_state] = 0.0
    grad_log_beta = float((G1 * R1).sum())
    grad_log_sigma = 0.0
    if model.hand and player.sigma > 0:
        Q3 = plan.Q.reshape(S, 4, L)[acting]
        p3, u3, h3 = pi3[acting], U3[acting], g3[acting] + y[acting, None, None] * pi3[acting]
        dLL_dK = np.einsum("sdi,sdj->ij", p3, u3)
        if model.plans:
            dLL_dK += np.einsum("sdi,sdc->ic", h3, Q3)
        grad_log_sigma = float((dLL_dK * dK).sum())
    grad_lapse = 0.0
    if model.lapses:
        q3 = plan.realised.reshape(S, 4, L)
        grad_lapse = float((W3 * (q3.sum(axis=1, keepdims=True) / 4 - q3))[acting].sum())
    return Likelihood(value, grad_R_S, grad_log_beta, grad_log_sigma, grad_lapse, plan)


@dataclass(frozen=True)
class PlayerFit:
    """The rewards theta (k,) and the player that maximise the likelihood, V (S,) at beta 1 there,
    the mean log likelihood per recorded step, and L-BFGS-B's report."""

    model: PlayerModel
    theta: np.ndarray
    player: Player
    V1: np.ndarray
    mean_log_likelihood: float
    converged: bool
    iterations: int
    message: str
    plan: PlayerPlan = field(repr=False)

    @property
    def beta_at_bound(self) -> bool:
        return min(abs(np.log(self.player.beta) - end) for end in beta_bounds(self.model)) < 1e-6

    def parameters(self) -> np.ndarray:
        """(p,) theta, then beta, then sigma and the lapse where the model has them (the bootstrap's vector)."""
        extra = [self.player.beta]
        if self.model.hand:
            extra.append(self.player.sigma)
        if self.model.lapses:
            extra.append(self.player.lapse)
        return np.append(self.theta, extra)


def _logit(p: float) -> float:
    return float(np.log(p) - np.log1p(-p))


def fit_player(
    mdp: MDP,
    unknowns: Unknowns,
    counts: np.ndarray,
    *,
    model: PlayerModel,
    rmax: float,
    start: tuple[np.ndarray, Player] | None = None,
    start_V: np.ndarray | None = None,
    scale: np.ndarray | None = None,
    value_tolerance: float = VALUE_TOLERANCE,
    gradient_tolerance: float = GRADIENT_TOLERANCE,
    max_iter: int = MAX_ITER,
) -> PlayerFit:
    """Maximise the mean log likelihood of counts N (S, A) over the unknowns (|theta| <= rmax), log beta,
    and, where `model` has them, log sigma and logit lapse, from `start` = (theta, player) (else theta 0,
    beta 1, sigma 1, lapse 0.02) and the soft values from `start_V` (S,, at beta 1).

    `scale` (p,): the variables' natural sizes (`curvature_scale`), over which the search runs (a warm
    start then converges in a few steps); without it the rewards move in units of rmax / 100.

    Raises ValueError without a recorded step, `Stopped` once the fit's stop check says so."""
    counts = np.asarray(counts, dtype=float)
    if counts.sum() <= 0:
        raise ValueError("the player model needs at least one recorded step")
    theta0, player0 = start if start is not None else (np.zeros(unknowns.k), Player(1.0, START_SIGMA, START_LAPSE))
    z0, bounds = _variables(model, theta0, player0, rmax=rmax)
    negative = _Objective(mdp, unknowns, counts, model, start_V)
    if scale is None:
        # Rewards run in hundreds, the other variables near 1: rewards in units of rmax / 100, so that
        # L-BFGS-B's first steps are of a sensible size in every direction.
        scale = np.ones(z0.size)
        scale[: unknowns.k] = max(rmax / 100.0, 1.0)
    scaled_bounds = [(low / u, high / u) for (low, high), u in zip(bounds, scale)]
    with one_blas_thread():
        result = minimize(lambda z: _scaled(negative, z, scale), z0 / scale, jac=True, method="L-BFGS-B",
                          bounds=scaled_bounds,
                          options={"maxiter": max_iter, "ftol": value_tolerance, "gtol": gradient_tolerance})
        theta, player = _unpack(model, unknowns.k, result.x * scale)
        final = log_likelihood(mdp, counts, unknowns.state_rewards(theta), model=model, player=player,
                               V0=negative.V, gradient=False)
    return PlayerFit(model=model, theta=np.asarray(theta, dtype=float), player=player, V1=final.plan.V,
                     mean_log_likelihood=final.value / counts.sum(), converged=bool(result.success),
                     iterations=int(result.nit), message=str(result.message), plan=final.plan)


def _variables(model: PlayerModel, theta: np.ndarray, player: Player, *,
               rmax: float) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """The search's variables z (p,) = theta, log beta, then log sigma and logit lapse where the model has
    them, and their bounds."""
    z = list(np.asarray(theta, dtype=float)) + [float(np.clip(np.log(player.beta), *beta_bounds(model)))]
    bounds = [(-rmax, rmax)] * len(theta) + [beta_bounds(model)]
    if model.hand:
        z.append(float(np.log(np.clip(player.sigma or START_SIGMA, *SIGMA_BOUNDS))))
        bounds.append((float(np.log(SIGMA_BOUNDS[0])), float(np.log(SIGMA_BOUNDS[1]))))
    if model.lapses:
        z.append(_logit(float(np.clip(player.lapse or START_LAPSE, *LAPSE_BOUNDS))))
        bounds.append((_logit(LAPSE_BOUNDS[0]), _logit(LAPSE_BOUNDS[1])))
    return np.asarray(z), bounds


def _unpack(model: PlayerModel, k: int, z: np.ndarray) -> tuple[np.ndarray, Player]:
    """(theta, player) from the search's variables (`_variables`)."""
    i = k + 1
    sigma = lapse = 0.0
    if model.hand:
        sigma, i = float(np.exp(z[i])), i + 1
    if model.lapses:
        lapse = float(1 / (1 + np.exp(-z[i])))
    return z[:k], Player(float(np.exp(z[k])), sigma, lapse)


class _Objective:
    """The mean negative log likelihood and its gradient over the search's variables, warm-starting each
    soft Bellman fixed point from the last (`V`)."""

    def __init__(self, mdp: MDP, unknowns: Unknowns, counts: np.ndarray, model: PlayerModel,
                 V: np.ndarray | None) -> None:
        self.mdp, self.unknowns, self.counts, self.model, self.V = mdp, unknowns, counts, model, V
        self.total = counts.sum()
        self.basis_T = unknowns.basis.T.tocsr()

    def __call__(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        theta, player = _unpack(self.model, self.unknowns.k, z)
        got = log_likelihood(self.mdp, self.counts, self.unknowns.state_rewards(theta), model=self.model,
                             player=player, V0=self.V)
        self.V = got.plan.V
        grad = [self.basis_T @ got.R_S, [got.log_beta]]
        if self.model.hand:
            grad.append([got.log_sigma])
        if self.model.lapses:
            grad.append([got.lapse * player.lapse * (1 - player.lapse)])
        return -got.value / self.total, -np.concatenate(grad) / self.total


def _scaled(negative, z: np.ndarray, unit: np.ndarray) -> tuple[float, np.ndarray]:
    value, gradient = negative(z * unit)
    return value, gradient * unit


def curvature_scale(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float) -> np.ndarray:
    """(p,) 1 / sqrt of the mean negative log likelihood's curvature along each search variable at `fit`,
    from central differences of the exact gradient; capped at rmax where it is (nearly) flat (a cliff
    nobody steps into), as `maxent.curvature_scale`."""
    z, bounds = _variables(fit.model, fit.theta, fit.player, rmax=rmax)
    negative = _Objective(mdp, unknowns, np.asarray(counts, dtype=float), fit.model, fit.V1)
    curvature = np.empty(z.size)
    with one_blas_thread():
        for j in range(z.size):
            h = 1e-4 * max(1.0, abs(z[j]))
            up, down = z.copy(), z.copy()
            up[j], down[j] = min(z[j] + h, bounds[j][1]), max(z[j] - h, bounds[j][0])
            curvature[j] = (negative(up)[1][j] - negative(down)[1][j]) / (up[j] - down[j])
    return np.minimum(1.0 / np.sqrt(np.maximum(curvature, 1.0 / rmax**2)), rmax)


# ---------------------------------------------------------------------------- choosing a model

FOLDS = 5
# A fold's refit starts at the full fit and stops sooner: its error is far below the held-out noise.
FOLD_VALUE_TOLERANCE = 1e-6
# A resample's refit runs over variables scaled to unit curvature (`curvature_scale`) and stops at this
# projected gradient, as maxent's does (`bootstrap.RESAMPLE_GRADIENT_TOLERANCE`).
RESAMPLE_GRADIENT_TOLERANCE = 1e-5
RESAMPLE_VALUE_TOLERANCE = 1e-12
REFIT_MAX_ITER = 200
# With fewer episodes than this there is no held-out choice.
MIN_EPISODES_TO_CHOOSE = 3


@dataclass(frozen=True)
class ModelChoice:
    """Which player model explains the recordings best on held-out episodes, and by how much.

    Attributes:
        name: the chosen model.
        held_out: per candidate, the log likelihood of each episode under the model fitted without
            its fold, summed over episodes (None where the choice was not made on held-out data).
        folds: how many folds the episodes were split into (0: no held-out choice).
        fits: per candidate, its fit to every episode.
        reason: one sentence for the reader.
        per_episode: per candidate, each episode's held-out log likelihood (E,) (None as held_out).
    """

    name: str
    held_out: dict[str, float] | None
    folds: int
    fits: dict[str, PlayerFit]
    reason: str
    per_episode: dict[str, np.ndarray] | None = None


def choose_player_model(
    mdp: MDP,
    unknowns: Unknowns,
    by_episode: sp.csr_matrix,
    *,
    rmax: float,
    candidates: tuple[str, ...] = CANDIDATES,
    folds: int = FOLDS,
    seed: int = 0,
) -> ModelChoice:
    """Fit each candidate model to the episodes (rows of `by_episode`, (E, S * A)) and choose by
    `folds`-fold held-out log likelihood of whole episodes: of the models within `SIMPLER_MARGIN` of
    the best, the one with the fewest parameters, the likeliest among those. With fewer than
    `MIN_EPISODES_TO_CHOOSE` episodes the choice is the ``ends`` model (the simplest with a person's
    episode end), said so."""
    by_episode = sp.csr_matrix(by_episode)
    counts = _counts_of(by_episode, mdp)
    E = by_episode.shape[0]
    models = [player_model(name) for name in candidates]
    if E < MIN_EPISODES_TO_CHOOSE:
        fit = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=rmax)
        return ModelChoice("ends", None, 0, {"ends": fit},
                           f"player model ends, without a held-out choice: {E} episode{'s' if E != 1 else ''} "
                           f"cannot be split into folds (a choice needs {MIN_EPISODES_TO_CHOOSE})")
    fits: dict[str, PlayerFit] = {}
    for model in models:
        # From the default start, and for a richer model also from where the one before it ended: the
        # likelihood is not concave, and either start alone can stop in a poorer optimum.
        tries = [fit_player(mdp, unknowns, counts, model=model, rmax=rmax)]
        previous = fits[models[models.index(model) - 1].name] if fits else None
        if previous is not None:
            start = (previous.theta, Player(previous.player.beta, previous.player.sigma or START_SIGMA,
                                            previous.player.lapse or START_LAPSE))
            tries.append(fit_player(mdp, unknowns, counts, model=model, rmax=rmax, start=start))
        fits[model.name] = max(tries, key=lambda fit: fit.mean_log_likelihood)
    k = min(folds, E)
    fold_of = np.random.default_rng(seed).permutation(np.arange(E) % k)
    per_episode = {model.name: np.zeros(E) for model in models}
    for f in range(k):
        test = np.flatnonzero(fold_of == f)
        train = _counts_of(by_episode[fold_of != f], mdp)
        for model in models:
            full = fits[model.name]
            part = fit_player(mdp, unknowns, train, model=model, rmax=rmax, start=(full.theta, full.player),
                              start_V=full.V1, value_tolerance=FOLD_VALUE_TOLERANCE, max_iter=REFIT_MAX_ITER)
            per_episode[model.name][test] = by_episode[test] @ part.plan.log_observed.ravel()
    held_out = {name: float(values.sum()) for name, values in per_episode.items()}
    best = max(held_out, key=held_out.__getitem__)
    standing = [m for m in models if held_out[best] - held_out[m.name] <= SIMPLER_MARGIN]
    fewest = min(m.extra_parameters for m in standing)
    chosen = max((m.name for m in standing if m.extra_parameters == fewest), key=held_out.__getitem__)
    steps = int(counts.sum())
    scores = ", ".join(f"{name} {held_out[name] / steps:.4f}" for name in candidates)
    why = (f"player model {chosen} chosen by {k}-fold held-out log likelihood of whole episodes, per step: "
           f"{scores}")
    if chosen != best:
        why += f" ({best} is no better by more than {SIMPLER_MARGIN:g} nats in all, so the simpler model stands)"
    return ModelChoice(chosen, held_out, k, fits, why, per_episode)


# A model with more parameters is chosen only if its held-out log likelihood beats the simpler one's by
# more than this (nats over all held-out episodes; cross-validation already charges for overfitting).
SIMPLER_MARGIN = 2.0
# Two models of equal size are told apart on held-out episodes when the mean of their paired per-episode log likelihood
# differences is this many standard errors above zero.
SIGNIFICANT_Z = 2.0


def significantly_better(first: np.ndarray, second: np.ndarray) -> bool:
    """Whether per-episode held-out log likelihoods `first` (E,) beat `second` (E,) beyond their noise."""
    difference = np.asarray(first) - np.asarray(second)
    spread = difference.std(ddof=1) if difference.size > 1 else 0.0
    if spread == 0:
        return bool(difference.sum() > 0)
    return bool(difference.mean() / (spread / np.sqrt(difference.size)) > SIGNIFICANT_Z)


def fit_given_model(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, *, model: PlayerModel, rmax: float) -> PlayerFit:
    """`fit_player` for one model named in advance, from the starts `choose_player_model` tries: the default,
    and for a model with a hand, where the simpler ``ends`` model ends (the likelier answer is kept), so that a
    model given by name finds the optimum the choice would have found."""
    tries = [fit_player(mdp, unknowns, counts, model=model, rmax=rmax)]
    if model.hand:
        simpler = fit_player(mdp, unknowns, counts, model=PLAYER_MODELS["ends"], rmax=rmax)
        tries.append(fit_player(mdp, unknowns, counts, model=model, rmax=rmax,
                                start=(simpler.theta, Player(simpler.player.beta, START_SIGMA, START_LAPSE))))
    return max(tries, key=lambda fit: fit.mean_log_likelihood)


def _counts_of(rows: sp.csr_matrix, mdp: MDP) -> np.ndarray:
    """(S, A) counts summed over episode rows (n, S * A)."""
    return np.asarray(rows.sum(axis=0)).reshape(mdp.n_states, mdp.n_actions)


@dataclass(frozen=True, eq=False)
class PlayerRefit:
    """How the bootstrap refits one resample's counts (S, A) with a player model: from the full fit's answer,
    over the variables' `scale` there (`curvature_scale`). Returns `PlayerFit.parameters()` (p,)."""

    mdp: MDP
    unknowns: Unknowns
    model: PlayerModel
    rmax: float
    start: tuple[np.ndarray, Player]
    start_V: np.ndarray | None = None
    scale: np.ndarray | None = None

    @property
    def size(self) -> int:
        """p: the unknowns, beta, and sigma and the lapse where the model has them."""
        return self.unknowns.k + 1 + self.model.extra_parameters

    def __call__(self, counts: np.ndarray) -> np.ndarray:
        return fit_player(self.mdp, self.unknowns, counts, model=self.model, rmax=self.rmax, start=self.start,
                          start_V=self.start_V, scale=self.scale, value_tolerance=RESAMPLE_VALUE_TOLERANCE,
                          gradient_tolerance=RESAMPLE_GRADIENT_TOLERANCE, max_iter=REFIT_MAX_ITER).parameters()


# A reward moved to its bound whose log likelihood falls by less than this (chi-square(1) at 95%, halved)
# is not bounded on that side by the data.
FLAT_DROP = 1.92
# Beyond this many unknowns on one side, only the joint move is tried (one soft Bellman fixed point each).
MAX_ONE_BY_ONE = 40


def flat_toward_bound(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, fit: PlayerFit, *, rmax: float) -> np.ndarray:
    """(k,) -1 where moving an unknown from its estimate to -rmax, +1 where moving it to +rmax, costs the
    likelihood less than `FLAT_DROP` (its value there is the optimiser's patience, not the data's), else 0.

    Each unknown moves toward the bound on its own side; all of one side move together first, and one
    by one only if that costs more (and there are at most `MAX_ONE_BY_ONE`)."""
    counts = np.asarray(counts, dtype=float)

    def ll(theta: np.ndarray) -> float:
        return log_likelihood(mdp, counts, unknowns.state_rewards(theta), model=fit.model, player=fit.player,
                              V0=fit.V1, gradient=False).value

    best = ll(fit.theta)
    out = np.zeros(unknowns.k, dtype=np.int64)
    for sign in (-1, 1):
        side = np.flatnonzero((np.sign(fit.theta) == sign) & (np.abs(fit.theta) < rmax * (1 - 1e-9)))
        if side.size == 0:
            continue
        moved = fit.theta.copy()
        moved[side] = sign * rmax
        if best - ll(moved) < FLAT_DROP:
            out[side] = sign
            continue
        if side.size > MAX_ONE_BY_ONE:
            continue
        for j in side:
            one = fit.theta.copy()
            one[j] = sign * rmax
            if best - ll(one) < FLAT_DROP:
                out[j] = sign
    return out
