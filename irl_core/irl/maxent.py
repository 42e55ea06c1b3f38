"""The paper's baseline: maximum-entropy IRL by maximum likelihood (Kim et al. 2021).

The expert is modelled as soft-optimal, pi(a | s) = exp(beta (Q(s, a) - V(s))) with the soft
Bellman equations

    Q(s, a) = R_S(s) + R_A(a) + gamma sum_s' P(s' | s, a) V(s'),
    V(s)    = (1/beta) log sum_a exp(beta Q(s, a))      (in every state, as planning.soft_value_iteration),

in the world's own transitions and with the known action cost (SPEC section 3). The fit
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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import minimize
from scipy.special import logsumexp, softmax

from irl_core.irl.qmap import Unknowns
from irl_core.mdp import MDP
from irl_core.planning import policy_matrix

SOFT_TOLERANCE = 1e-13
SOFT_MAX_ITER = 200
# L-BFGS-B stops when the projected gradient of the mean log likelihood is below this ...
GRADIENT_TOLERANCE = 1e-10
# ... or when an iteration improves it by less than this (relative).
VALUE_TOLERANCE = 1e-15
MAX_ITER = 2000


@dataclass(frozen=True)
class SoftPlan:
    """The soft Bellman fixed point: V (S,), Q (S, A), pi (S, A), solves used."""

    V: np.ndarray
    Q: np.ndarray
    policy: np.ndarray
    iterations: int


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

    Raises RuntimeError if max|V_k - V_{k-1}| is not below tol * max(1, |V|) after max_iter solves.
    """
    R = mdp.reward_matrix(R_S)
    identity = sp.identity(mdp.n_states, format="csc")
    V = np.zeros(mdp.n_states) if V0 is None else np.asarray(V0, dtype=float)
    for iteration in range(1, max_iter + 1):
        Q = R + mdp.gamma * mdp.expected_next(V)
        pi = softmax(beta * Q, axis=1)
        P_pi, _ = policy_matrix(mdp, pi)
        entropy = -(pi * np.log(np.where(pi > 0, pi, 1.0))).sum(axis=1)
        V_new = spla.spsolve(identity - mdp.gamma * P_pi.tocsc(), (pi * R).sum(axis=1) + entropy / beta)
        change = float(np.abs(V_new - V).max())
        V = V_new
        if change <= tol * max(1.0, float(np.abs(V).max())):
            Q = R + mdp.gamma * mdp.expected_next(V)
            return SoftPlan(V=V, Q=Q, policy=softmax(beta * Q, axis=1), iterations=iteration)
    raise RuntimeError(f"soft policy iteration did not converge in {max_iter} solves")


def log_likelihood(
    mdp: MDP, counts: np.ndarray, R_S: np.ndarray, *, beta: float, V0: np.ndarray | None = None
) -> tuple[float, np.ndarray, SoftPlan]:
    """LL(R_S) and its gradient dLL/dR_S (S,) for demonstrated counts N (S, A)."""
    plan = soft_bellman(mdp, R_S, beta=beta, V0=V0)
    acting = mdp.nonterminal
    log_pi = beta * plan.Q - logsumexp(beta * plan.Q, axis=1, keepdims=True)
    ll = float((counts[acting] * log_pi[acting]).sum())

    visits = counts.sum(axis=1)
    successors = mdp.gamma * (counts.ravel() @ mdp.P)
    P_pi, _ = policy_matrix(mdp, plan.policy)
    system = (sp.identity(mdp.n_states, format="csc") - mdp.gamma * P_pi.tocsc()).T.tocsc()
    y = spla.spsolve(system, successors - visits)
    y[mdp.exit_state] = 0.0  # the exit's reward is fixed at 0
    return ll, beta * (visits + y), plan


@dataclass(frozen=True)
class MaxEntSolution:
    """theta (k,), the soft V (S,) there, the mean log likelihood, and L-BFGS-B's report."""

    theta: np.ndarray
    V: np.ndarray
    mean_log_likelihood: float
    converged: bool
    iterations: int
    message: str


def fit_maxent(
    mdp: MDP, unknowns: Unknowns, counts: np.ndarray, *, beta: float, rmax: float
) -> MaxEntSolution:
    """Maximise the mean log likelihood over the unknowns, |theta| <= rmax, from theta = 0."""
    counts = np.asarray(counts, dtype=float)
    total = counts.sum()
    if total <= 0:
        raise ValueError("maxent needs at least one demonstrated step")
    if unknowns.k == 0:
        plan = soft_bellman(mdp, unknowns.fixed, beta=beta)
        ll, _, _ = log_likelihood(mdp, counts, unknowns.fixed, beta=beta)
        return MaxEntSolution(np.zeros(0), plan.V, ll / total, True, 0, "no unknowns")
    basis = unknowns.basis.tocsc()
    warm = {"V": None}

    def negative(theta: np.ndarray) -> tuple[float, np.ndarray]:
        ll, grad, plan = log_likelihood(mdp, counts, unknowns.state_rewards(theta), beta=beta, V0=warm["V"])
        warm["V"] = plan.V
        return -ll / total, -(basis.T @ grad) / total

    result = minimize(
        negative,
        np.zeros(unknowns.k),
        jac=True,
        method="L-BFGS-B",
        bounds=[(-rmax, rmax)] * unknowns.k,
        options={"maxiter": MAX_ITER, "gtol": GRADIENT_TOLERANCE, "ftol": VALUE_TOLERANCE},
    )
    theta = np.asarray(result.x, dtype=float)
    plan = soft_bellman(mdp, unknowns.state_rewards(theta), beta=beta)
    return MaxEntSolution(
        theta=theta,
        V=plan.V,
        mean_log_likelihood=float(-result.fun),
        converged=bool(result.success),
        iterations=int(result.nit),
        message=str(result.message),
    )
