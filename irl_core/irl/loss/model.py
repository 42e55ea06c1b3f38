"""The paper's loss IRL agent, the problem: a convex loss for demonstrations that are not quite optimal.

Hanslope & Aitchison, section "Game and Loss IRL agent". A human does not follow one
deterministic optimal policy, so instead of requiring pi(s) to be optimal the agent takes
pi(s, a), the demonstrated action frequencies, and minimises

    L(R_S) = sum over demonstrated s of exp(ReLU(z_s)) + lambda ||R_S||_1,
    z_s    = sum_a pi(s, a) [max_{a' != a} Q(s, a') - Q(s, a)],

subject to |R_S| <= rmax and (docs/fitting.md) V(s) = sum_a pi(s, a) Q(s, a) at demonstrated
s, V(s) >= Q(s, a) at every other non-terminal s, V(s) = R_S(s) at terminal cells and
V(exit) = 0: the same affine Q (`qmap`) and value bound as the lp. z_s <= 0 when the most
frequent action has the largest Q; each term is then 1, and it grows exponentially with
the evidence against the reward.

Convexity (DCP). Q is affine in x = [theta; V]; max_{a' != a} Q(s, a') is convex (an
epigraph variable m_{s,a} >= Q(s, a') per demonstrated pair); a non-negative combination
minus an affine term is convex; ReLU of a convex function is convex; exp is convex and
non-decreasing. `loss_problem` states exactly this in cvxpy, which accepts it as DCP.

This module states the problem (its constraints, the cvxpy model, the loss evaluated
directly); `irl_core.irl.loss.solve` solves it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from irl_core.irl.lp.highs import LinearProgram, linear_program
from irl_core.irl.lp.margin import check_bounds
from irl_core.irl.qmap import QMap

if TYPE_CHECKING:
    import cvxpy as cp


@dataclass(frozen=True, eq=False)
class LossConstraints:
    """The loss agent's constraints and z_s, over y = [x; auxiliaries], x = [theta; V].

    `program` (cost 0): row_lower <= A y <= row_upper, lower <= y <= upper; z = Z y + z0 (d,). The auxiliaries
    bound max_{a' != a} Q(s, a') for each demonstrated pair (see `_rival_rows`).

    Attributes:
        demonstrated: (d,) demonstrated states.
        pairs: (K, 2) demonstrated (state, action) pairs.
    """

    qmap: QMap
    frequencies: np.ndarray
    demonstrated: np.ndarray
    pairs: np.ndarray
    program: LinearProgram
    Z: sp.csr_matrix
    z0: np.ndarray


def loss_constraints(qmap: QMap, frequencies: np.ndarray, *, rmax: float) -> LossConstraints:
    """The constraints for demonstrated frequencies pi (S, A) (rows of 0: not demonstrated)."""
    check_bounds(rmax=rmax)
    mdp = qmap.mdp
    S, A, k = mdp.n_states, mdp.n_actions, qmap.k
    pi = np.asarray(frequencies, dtype=float)
    shown = pi.sum(axis=1) > 0
    if np.any(shown & ~mdp.nonterminal):
        raise ValueError("frequencies are given at a terminal state or the exit")
    d = np.flatnonzero(shown)
    pair_s, pair_a = np.nonzero(pi > 0)
    vmax = qmap.value_bound(rmax)
    rivals, rivals_upper, m = _rival_rows(qmap, d, pair_s, pair_a)
    n_aux = rivals.shape[1] - qmap.n

    def widen(rows_x: sp.spmatrix) -> sp.csr_matrix:
        return sp.hstack([rows_x, sp.csr_matrix((rows_x.shape[0], n_aux))], format="csr")

    # V(s) = sum_a pi(s, a) Q(s, a) at demonstrated s.
    weights = sp.csr_matrix(
        (pi[d].ravel(), (np.repeat(np.arange(d.size), A), (d[:, None] * A + np.arange(A)).ravel())),
        shape=(d.size, S * A),
    )
    average = qmap.value_selector(d) - weights @ qmap.M
    demanded = weights @ qmap.q0
    # V(s) >= Q(s, a) at non-terminal, non-demonstrated s.
    free = np.flatnonzero(mdp.nonterminal & ~shown)
    rows_free, q0_free = qmap.rows(np.repeat(free, A), np.tile(np.arange(A), free.size))
    better = rows_free - qmap.value_selector(np.repeat(free, A))
    # z_s = sum_j pi_j (m_j - Q(s_j, a_j)), summed over the pairs of each state.
    K = pair_s.size
    to_state = sp.csr_matrix((pi[pair_s, pair_a], (np.searchsorted(d, pair_s), np.arange(K))), shape=(d.size, K))
    rows_k, q0_k = qmap.rows(pair_s, pair_a)
    pick_m = sp.csr_matrix((np.ones(K), (np.arange(K), m)), shape=(K, n_aux))

    return LossConstraints(
        qmap=qmap,
        frequencies=pi,
        demonstrated=d,
        pairs=np.column_stack([pair_s, pair_a]),
        program=linear_program(
            sp.vstack([widen(qmap.E), widen(average), widen(better), rivals], format="csr"),
            np.concatenate([qmap.e, demanded, np.full(better.shape[0] + rivals.shape[0], -np.inf)]),
            np.concatenate([qmap.e, demanded, -q0_free, rivals_upper]),
            # Every Q lies in [-vmax, vmax], so the rival maxima may be bounded below by -vmax.
            np.concatenate([np.full(k, -rmax), np.full(S + n_aux, -vmax)]),
            np.concatenate([np.full(k, rmax), np.full(S, vmax), np.full(n_aux, np.inf)]),
        ),
        Z=sp.hstack([-(to_state @ rows_k), to_state @ pick_m], format="csr"),
        z0=-(to_state @ q0_k),
    )


def _rival_rows(
    qmap: QMap, d: np.ndarray, pair_s: np.ndarray, pair_a: np.ndarray
) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """Rows making m_j >= max_{a' != a_j} Q(s_j, a') for every demonstrated pair j.

    Written directly this takes A - 1 rows per pair, K (A - 1) in all: tens of thousands
    for a noisy expert who tried most actions. Per demonstrated state, with U its
    undemonstrated actions and D_1..D_k its demonstrated ones, we use instead

        M >= Q(s, a') (a' in U);  P_j >= Q(s, D_j), P_j >= P_{j-1} (P_0 = M);
        S_j >= Q(s, D_j), S_j >= S_{j+1};  m_j >= P_{j-1},  m_j >= S_{j+1},

    so P_{j-1} bounds everything before D_j and S_{j+1} everything after: A + 6k rows.
    The objective only ever pushes these maxima down, so the relaxation is exact.

    Returns (rows over [x; M (d); P (K); S (K); m (K)], their upper bounds (<=), the
    column of each m_j within the auxiliary block).
    """
    A, n = qmap.mdp.n_actions, qmap.n
    K, n_d = pair_s.size, d.size
    position = np.searchsorted(d, pair_s)
    first = np.r_[True, position[1:] != position[:-1]] if K else np.zeros(0, bool)
    last = np.r_[position[1:] != position[:-1], True] if K else np.zeros(0, bool)
    M_col, P_col, S_col, m_col = position, n_d + np.arange(K), n_d + K + np.arange(K), n_d + 2 * K + np.arange(K)
    n_aux = n_d + 3 * K

    def below(rows_x: sp.csr_matrix, q0: np.ndarray, aux: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """Q rows <= aux columns: rows_x @ x - aux <= -q0."""
        minus = sp.csr_matrix((-np.ones(aux.size), (np.arange(aux.size), aux)), shape=(aux.size, n_aux))
        return sp.hstack([rows_x, minus], format="csr"), -q0

    def order(low: np.ndarray, high: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """aux[low] <= aux[high]."""
        count = low.size
        rows = np.repeat(np.arange(count), 2)
        cols = np.column_stack([low, high]).ravel()
        data = np.tile([1.0, -1.0], count)
        block = sp.csr_matrix((data, (rows, cols)), shape=(count, n_aux))
        return sp.hstack([sp.csr_matrix((count, n)), block], format="csr"), np.zeros(count)

    shown = np.zeros((n_d, A), dtype=bool)
    shown[position, pair_a] = True
    u_state, u_action = np.nonzero(~shown)
    rows_u, q0_u = qmap.rows(d[u_state], u_action)
    rows_pairs, q0_pairs = qmap.rows(pair_s, pair_a)
    parts = [
        below(rows_u, q0_u, u_state),
        below(rows_pairs, q0_pairs, P_col),
        below(rows_pairs, q0_pairs, S_col),
        order(np.where(first, M_col, np.roll(P_col, 1)), P_col),
        order(S_col[1:][~last[:-1]], S_col[:-1][~last[:-1]]),
        order(np.where(first, M_col, np.roll(P_col, 1)), m_col),
        order(S_col[1:][~last[:-1]], m_col[:-1][~last[:-1]]),
    ]
    return (
        sp.vstack([p[0] for p in parts], format="csr"),
        np.concatenate([p[1] for p in parts]),
        m_col,
    )


def loss_problem(constraints: LossConstraints, *, lam: float = 0.0) -> tuple[cp.Problem, cp.Variable]:
    """The paper's loss exactly as written, as a cvxpy problem over y = [theta; V; auxiliaries].

    minimise sum_s exp(ReLU(z_s)) + lambda ||R_S||_1 subject to the loss agent's
    constraints. cvxpy accepts it as DCP; `fit_loss` solves the same problem without cones.
    """
    import cvxpy as cp  # only the model needs it; the solve path does not

    c, lp = constraints, constraints.program
    y = cp.Variable(lp.shape[1], name="y")
    eq = lp.row_lower == lp.row_upper
    bounded = np.isfinite(lp.lower)
    k = c.qmap.k
    l1 = c.qmap.unknowns.weight @ cp.abs(y[:k]) if k else 0.0
    problem = cp.Problem(
        cp.Minimize(cp.sum(cp.exp(cp.pos(c.Z @ y + c.z0))) + lam * l1),
        [
            lp.A[eq] @ y == lp.row_lower[eq],
            lp.A[~eq] @ y <= lp.row_upper[~eq],
            y[bounded] >= lp.lower[bounded],
            y[bounded] <= lp.upper[bounded],
        ],
    )
    return problem, y


def relu_terms(qmap: QMap, frequencies: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(d,) z_s at x = [theta; V] for each demonstrated state, with the max over a' != a exact."""
    pi = np.asarray(frequencies, dtype=float)
    Q = qmap.q(x)
    order = np.argsort(-Q, axis=1, kind="stable")
    best, second = order[:, 0], order[:, 1]
    rows = np.arange(Q.shape[0])
    rival = np.repeat(Q[rows, best][:, None], Q.shape[1], axis=1)
    rival[rows, best] = Q[rows, second]
    shown = pi.sum(axis=1) > 0
    return (pi * (rival - Q)).sum(axis=1)[shown]
