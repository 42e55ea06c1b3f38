"""The paper's loss IRL agent: a convex loss for demonstrations that are not quite optimal.

Hanslope & Aitchison, section "Game and Loss IRL agent". A human does not follow one
deterministic optimal policy, so instead of requiring pi(s) to be optimal the agent takes
pi(s, a), the demonstrated action frequencies, and minimises

    L(R_S) = sum over demonstrated s of exp(ReLU(z_s)) + lambda ||R_S||_1,
    z_s    = sum_a pi(s, a) [max_{a' != a} Q(s, a') - Q(s, a)],

subject to |R_S| <= rmax and (SPEC section 3) V(s) = sum_a pi(s, a) Q(s, a) at demonstrated
s, V(s) >= Q(s, a) at every other non-terminal s, V(s) = R_S(s) at terminal cells and
V(exit) = 0 (the same affine Q as the lp, `qmap`, and the same value bound). z_s <= 0 when
the most frequent action has the largest Q; each term is 1 then and grows exponentially
with the evidence against the reward.

Convexity (DCP): Q is affine in x = [theta; V]; max_{a' != a} Q(s, a') is convex (we write
it as an epigraph variable m_{s,a} >= Q(s, a') for each demonstrated pair); a non-negative
combination minus an affine term is convex; ReLU (cvxpy ``pos``) of a convex function is
convex; exp is convex and non-decreasing, so exp(ReLU(z_s)) is convex. `loss_problem`
builds exactly this, and cvxpy accepts it.

Robustness. Q differences are in reward units (hundreds), so exp(z) overflows long before
a solver could use it. Three steps keep every exponential small without changing the answer:

1. Minimise log sum_s exp(ReLU(z_s)) instead (for lambda = 0). log is increasing, so the
   minimisers are the same; cvxpy writes log-sum-exp <= tau as sum exp(v - tau) <= 1, whose
   exponents are <= 0 at every feasible point. Its value is tau* = log L*.
2. With lambda > 0, minimise exp(tau - tau*) + lambda e^-tau* ||R_S||_1 with
   tau >= log-sum-exp(ReLU(z)): the true objective divided by the constant L*, so the same
   minimisers, with exponents near 0.
3. Many rewards often minimise the loss equally (every reward that makes each demonstrated
   action the best one reaches the floor L = number of demonstrated states). To make the
   answer reproducible a second, lexicographic stage keeps the first stage's objective within
   a relative 1e-6 of its optimum and picks the reward of smallest weighted ||R_S||_1 (plus
   1e-6 of a squared norm, which makes the choice unique). When the two stages' rewards
   differ, the result says the minimiser is not unique.

Solver: Clarabel (interior point, exponential cones), SCS if Clarabel fails.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from irl_core.irl.qmap import QMap
from irl_core.irl.result import SolverError

# The second stage may spend this much (relative) of the first stage's optimum.
LEXICOGRAPHIC_SLACK = 1e-6
# Weight of the squared norm that makes the second stage's minimiser unique.
TIE_BREAK = 1e-6
# Two unknowns differing by more than this (relative to rmax) count as different rewards.
UNIQUE_TOLERANCE = 1e-3
SOLVERS = ("CLARABEL", "SCS")


@dataclass(frozen=True, eq=False)
class LossModel:
    """The loss agent's variables and affine pieces, as cvxpy expressions.

    Attributes:
        x: variable (k + S,) = [theta; V].
        m: variable (K,), m_k >= max_{a' != a_k} Q(s_k, a') for each demonstrated pair k.
        z: expression (d,), z_s per demonstrated state.
        constraints: the feasible set (values, bounds and the epigraph of m).
        l1: expression, the weighted ||R_S||_1 = weight @ |theta|.
    """

    qmap: QMap
    frequencies: np.ndarray
    x: cp.Variable
    m: cp.Variable
    z: cp.Expression
    constraints: list[cp.Constraint]
    l1: cp.Expression


def loss_model(qmap: QMap, frequencies: np.ndarray, *, rmax: float) -> LossModel:
    """Variables and constraints for demonstrated frequencies pi (S, A) (rows of 0: not demonstrated)."""
    mdp = qmap.mdp
    S, A, k, n = mdp.n_states, mdp.n_actions, qmap.k, qmap.n
    pi = np.asarray(frequencies, dtype=float)
    shown = pi.sum(axis=1) > 0
    d = np.flatnonzero(shown)

    # V(s) >= Q(s, a) at non-terminal, non-demonstrated s.
    free = np.flatnonzero(mdp.nonterminal & ~shown)
    rows_q, q0 = qmap.rows(np.repeat(free, A), np.tile(np.arange(A), free.size))
    better = rows_q - qmap.value_selector(np.repeat(free, A))

    # V(s) = sum_a pi(s, a) Q(s, a) at demonstrated s.
    weights = sp.csr_matrix(
        (pi[d].ravel(), (np.repeat(np.arange(d.size), A), (d[:, None] * A + np.arange(A)).ravel())),
        shape=(d.size, S * A),
    )
    average = qmap.value_selector(d) - weights @ qmap.M

    # Demonstrated pairs (s_k, a_k) and the epigraph m_k >= Q(s_k, a') for a' != a_k.
    pair_s, pair_a = np.nonzero(pi > 0)
    K = pair_s.size
    others = np.tile(np.arange(A), K) != np.repeat(pair_a, A)
    rows_o, q0_o = qmap.rows(np.repeat(pair_s, A)[others], np.tile(np.arange(A), K)[others])
    pick_m = sp.csr_matrix(
        (np.ones(int(others.sum())), (np.arange(int(others.sum())), np.repeat(np.arange(K), A)[others])), shape=(others.sum(), K)
    )

    # z_s = sum_k pi_k (m_k - Q(s_k, a_k)), summed per demonstrated state.
    state_row = np.searchsorted(d, pair_s)
    pair_weight = pi[pair_s, pair_a]
    to_state = sp.csr_matrix((pair_weight, (state_row, np.arange(K))), shape=(d.size, K))
    rows_k, q0_k = qmap.rows(pair_s, pair_a)

    x = cp.Variable(n, name="x")
    m = cp.Variable(K, name="m")
    vmax = qmap.value_bound(rmax)
    lower = np.concatenate([np.full(k, -rmax), np.full(S, -vmax)])
    constraints = [
        qmap.E @ x == qmap.e,
        average @ x == weights @ qmap.q0,
        x >= lower,
        x <= -lower,
        rows_o @ x + q0_o <= pick_m @ m,
    ]
    if free.size:
        constraints.append(better @ x <= -q0)
    z = to_state @ m - (to_state @ rows_k) @ x - to_state @ q0_k
    l1 = qmap.unknowns.weight @ cp.abs(x[:k]) if k else cp.Constant(0.0)
    return LossModel(qmap, pi, x, m, z, constraints, l1)


def loss_problem(model: LossModel, *, lam: float = 0.0) -> cp.Problem:
    """The paper's loss exactly as written: minimise sum exp(ReLU(z)) + lambda ||R_S||_1.

    Convex and DCP; `fit_loss` solves an equivalent, numerically safer form of it.
    """
    return cp.Problem(cp.Minimize(cp.sum(cp.exp(cp.pos(model.z))) + lam * model.l1), model.constraints)


def loss_value(qmap: QMap, frequencies: np.ndarray, x: np.ndarray, *, lam: float = 0.0) -> float:
    """L(R_S) at x = [theta; V], evaluated directly with numpy (for checks and reports)."""
    pi = np.asarray(frequencies, dtype=float)
    Q = qmap.q(x)
    shown = pi.sum(axis=1) > 0
    top2 = np.sort(Q, axis=1)[:, -2:]
    # max over a' != a: the best Q unless a is the (first) best action, then the second best.
    best_action = Q.argmax(axis=1)
    rival = np.where(np.arange(Q.shape[1])[None, :] == best_action[:, None], top2[:, :1], top2[:, 1:])
    z = (pi * (rival - Q)).sum(axis=1)[shown]
    theta, _ = qmap.split(x)
    return float(np.exp(np.maximum(z, 0.0)).sum() + lam * qmap.unknowns.weight @ np.abs(theta))


@dataclass(frozen=True)
class LossSolution:
    """The loss agent's answer: x = [theta; V], the loss there, and what to tell the user."""

    x: np.ndarray
    loss: float
    status: str
    unique: bool
    notes: list[str] = field(default_factory=list)


def fit_loss(qmap: QMap, frequencies: np.ndarray, *, rmax: float, lam: float = 0.0) -> LossSolution:
    """Minimise the loss (robust form), then pick the smallest-||R_S||_1 minimiser."""
    model = loss_model(qmap, frequencies, rmax=rmax)
    k = qmap.k
    relu = cp.pos(model.z)
    log_loss = cp.log_sum_exp(relu)

    status = _solve(cp.Problem(cp.Minimize(log_loss), model.constraints))
    log_best = float(log_loss.value)
    if lam > 0:
        tau = cp.Variable(name="tau")
        scaled = cp.exp(tau - log_best) + lam * np.exp(-log_best) * model.l1
        first = cp.Problem(cp.Minimize(scaled), [*model.constraints, log_loss <= tau])
        status = _worse(status, _solve(first))
        level = [scaled <= float(scaled.value) * (1 + LEXICOGRAPHIC_SLACK), log_loss <= tau]
    else:
        level = [log_loss <= log_best + LEXICOGRAPHIC_SLACK]
    first_theta = model.x.value[:k].copy()

    rmax_scale = max(rmax, 1.0)
    tie_break = TIE_BREAK * cp.sum_squares(cp.multiply(np.sqrt(qmap.unknowns.weight), model.x[:k])) / rmax_scale
    second = cp.Problem(cp.Minimize(model.l1 + tie_break), [*model.constraints, *level])
    status = _worse(status, _solve(second))
    x = np.asarray(model.x.value, dtype=float)

    unique = bool(np.max(np.abs(x[:k] - first_theta), initial=0.0) <= UNIQUE_TOLERANCE * rmax_scale)
    notes = []
    if not unique:
        notes.append(
            "not unique: many rewards minimise the loss equally; shown is the one with the smallest ||R_S||_1"
        )
    return LossSolution(x=x, loss=loss_value(qmap, frequencies, x, lam=lam), status=status, unique=unique, notes=notes)


def _solve(problem: cp.Problem) -> str:
    """Solve with the first solver that succeeds; the status it reached."""
    failures = []
    for solver in SOLVERS:
        try:
            problem.solve(solver=solver)
        except cp.SolverError as exc:
            failures.append(f"{solver}: {exc}")
            continue
        if problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return problem.status
        failures.append(f"{solver}: {problem.status}")
    raise SolverError("the loss could not be minimised (" + "; ".join(failures) + ")")


def _worse(a: str, b: str) -> str:
    return a if a != cp.OPTIMAL else b
