"""The simple IRL agent's LP as arrays: its feasible set and its margin LP in slack form.

The maths is in `lp`'s docstring (the paper's constraints, the slack form, the row
generation's seed); this module builds them over x = [theta (k,); V (S,)] from a `QMap`, and
`lp` solves them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.irl.lp.highs import LinearProgram, linear_program
from irl_core.irl.qmap import QMap


@dataclass(frozen=True, eq=False)
class LPConstraints:
    """The lp feasible set over x = [theta (k,); V (S,)] as a `LinearProgram` (cost 0).

    Attributes:
        qmap: the Q map the rows were built from.
        policy: (S,) pi(s), the demonstrated action, or -1 where nothing was demonstrated.
        program: the rows and bounds.
    """

    qmap: QMap
    policy: np.ndarray
    program: LinearProgram

    @property
    def demonstrated(self) -> np.ndarray:
        """(d,) the demonstrated states, ascending."""
        return np.flatnonzero(self.policy >= 0)

    def violation(self, x: np.ndarray) -> float:
        """The largest amount by which x breaks a constraint or a bound (0 when feasible)."""
        return self.program.violation(x)


def check_bounds(*, rmax: float, lam: float = 0.0) -> None:
    """Raise ValueError unless rmax is a positive number and lambda a non-negative one (not inf)."""
    if not (np.isfinite(rmax) and rmax > 0):
        raise ValueError(f"rmax must be a positive finite number, not {rmax}")
    if not (np.isfinite(lam) and lam >= 0):
        raise ValueError(f"lambda must be a finite number >= 0, not {lam}")


def _policy(qmap: QMap, policy: np.ndarray) -> np.ndarray:
    policy = np.asarray(policy, dtype=np.int64)
    if np.any((policy >= 0) & ~qmap.mdp.nonterminal):
        raise ValueError("a policy is given at a terminal state or the exit")
    return policy


def _rivals(qmap: QMap, policy: np.ndarray) -> np.ndarray:
    """(S, A) True at the pairs (s, a) with a row V(s) >= Q(s, a): non-terminal s, a != pi(s)."""
    A = qmap.mdp.n_actions
    rivals = np.repeat(qmap.mdp.nonterminal[:, None], A, axis=1)
    shown = np.flatnonzero(policy >= 0)
    rivals[shown, policy[shown]] = False
    return rivals


def lp_constraints(qmap: QMap, policy: np.ndarray, *, rmax: float) -> LPConstraints:
    """The lp feasible set for the demonstrated policy (S,) (-1: not demonstrated)."""
    check_bounds(rmax=rmax)
    policy = _policy(qmap, policy)
    s_rival, a_rival = np.nonzero(_rivals(qmap, policy))
    rows_q, q0 = qmap.rows(s_rival, a_rival)
    better = rows_q - qmap.value_selector(s_rival)  # Q(s, a) - V(s) <= -q0
    d = np.flatnonzero(policy >= 0)
    rows_pi, q0_pi = qmap.rows(d, policy[d])
    attains = qmap.value_selector(d) - rows_pi  # V(s) - Q(s, pi(s)) = q0
    vmax = qmap.value_bound(rmax)
    lower = np.concatenate([np.full(qmap.k, -rmax), np.full(qmap.mdp.n_states, -vmax)])
    program = linear_program(
        sp.vstack([better, attains, qmap.E], format="csr"),
        np.concatenate([np.full(better.shape[0], -np.inf), q0_pi, qmap.e]),
        np.concatenate([-q0, q0_pi, qmap.e]),
        lower,
        -lower,
    )
    return LPConstraints(qmap, policy, program)


@dataclass(frozen=True, eq=False)
class MarginLP:
    """The slack-form margin LP over z = [theta; V; m (d,); u (k,) if lambda > 0].

    `base` holds the rows every model keeps (terminal cells, V(s) = Q(s, pi(s)), u >= |theta|),
    the bounds and the cost (minimise -sum m + lambda ||R_S||_1); the family rows
    V(s) - Q(s, a) - m_s >= q0(s, a), one per (s, a) with `rivals[s, a]` (m_s only at
    demonstrated s), are built on demand by `rows`.

    Attributes:
        qmap, policy: as in `LPConstraints`.
        rivals: (S, A) the pairs of the family.
        base: the rows always present, with the bounds and cost of every column.
    """

    qmap: QMap
    policy: np.ndarray
    rivals: np.ndarray
    base: LinearProgram

    @property
    def demonstrated(self) -> np.ndarray:
        return np.flatnonzero(self.policy >= 0)

    def rows(self, states: np.ndarray, actions: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """The family rows of the pairs (states[i], actions[i]) and their lower bounds (upper: inf)."""
        qmap, n_col = self.qmap, self.base.shape[1]
        rows_q, q0 = qmap.rows(states, actions)
        slack = qmap.value_selector(states) - rows_q
        shown = self.policy[states] >= 0
        m_col = np.searchsorted(self.demonstrated, states[shown])
        minus_m = sp.csr_matrix((-np.ones(m_col.size), (np.flatnonzero(shown), m_col)), shape=(states.size, n_col - qmap.n))
        return sp.hstack([slack, minus_m], format="csr"), q0

    def slacks(self, z: np.ndarray) -> np.ndarray:
        """(S, A) V(s) - Q(s, a) - m_s at z for every pair (meaningful where `rivals`)."""
        qmap = self.qmap
        x = z[: qmap.n]
        m = np.zeros(qmap.mdp.n_states)
        m[self.demonstrated] = z[qmap.n : qmap.n + self.demonstrated.size]
        return (x[qmap.k :] - m)[:, None] - qmap.q(x)

    def full(self) -> LinearProgram:
        """The whole LP: the base rows and every family row."""
        family, q0 = self.rows(*np.nonzero(self.rivals))
        b = self.base
        return LinearProgram(
            sp.vstack([b.A, family], format="csr"),
            np.concatenate([b.row_lower, q0]),
            np.concatenate([b.row_upper, np.full(q0.size, np.inf)]),
            b.lower, b.upper, b.cost,
        )


def margin_lp(constraints: LPConstraints, *, lam: float = 0.0) -> MarginLP:
    """The paper's objective on the feasible set, in slack form: maximise sum m - lambda ||R_S||_1."""
    qmap, policy = constraints.qmap, constraints.policy
    k, n = qmap.k, qmap.n
    rmax = float(constraints.program.upper[:k].max(initial=1.0))
    check_bounds(rmax=rmax, lam=lam)
    d = constraints.demonstrated
    n_u = k if lam > 0 else 0
    n_col = n + d.size + n_u

    rows_pi, q0_pi = qmap.rows(d, policy[d])
    blocks = [qmap.E, qmap.value_selector(d) - rows_pi]
    row_lower, row_upper = [qmap.e, q0_pi], [qmap.e, q0_pi]
    blocks = [sp.hstack([b, sp.csr_matrix((b.shape[0], n_col - n))]) for b in blocks]
    if n_u:
        # u >= theta and u >= -theta.
        eye = sp.identity(k, format="csr")
        zeros = sp.csr_matrix((k, n - k + d.size))
        blocks += [sp.hstack([eye, zeros, -eye]), sp.hstack([-eye, zeros, -eye])]
        row_lower.append(np.full(2 * k, -np.inf))
        row_upper.append(np.zeros(2 * k))

    cost = np.zeros(n_col)
    cost[n : n + d.size] = -1.0
    cost[n + d.size :] = lam * qmap.unknowns.weight[:n_u]
    # m_s = V(s) - Q(s, a) is at most twice the value bound: a bound no optimum reaches.
    vmax = float(constraints.program.upper[k:n].max(initial=1.0))
    base = linear_program(
        sp.vstack(blocks, format="csr"),
        np.concatenate(row_lower),
        np.concatenate(row_upper),
        np.concatenate([constraints.program.lower, np.zeros(d.size + n_u)]),
        np.concatenate([constraints.program.upper, np.full(d.size, 2 * vmax), np.full(n_u, rmax)]),
        cost,
    )
    return MarginLP(qmap, policy, _rivals(qmap, policy), base)


def seed_pairs(problem: MarginLP) -> np.ndarray:
    """(S, A) the family rows a row-generation model starts with (see the module docstring)."""
    mdp = problem.qmap.mdp
    L = mdp.levels
    direction = np.arange(mdp.n_actions) // L
    carefulness = np.arange(mdp.n_actions) % L + 1
    policy = problem.policy
    shown = policy >= 0
    pi = np.where(shown, policy, 0)
    same_direction = direction[None, :] == direction[pi][:, None]
    gap = np.abs(carefulness[None, :] - carefulness[pi][:, None])
    near = np.where(same_direction, gap == 1, gap == 0)
    seeds = np.where(shown[:, None], near, (carefulness == 1)[None, :])
    return seeds & problem.rivals


def first_round_rows(problem: MarginLP) -> int:
    """The rows of the margin LP's first round: the base rows and the seed (`seed_pairs`)."""
    return problem.base.shape[0] + int(seed_pairs(problem).sum())


def shares_terminal_unknowns(problem: MarginLP) -> bool:
    """Whether one reward unknown stands for several terminal cells (what `--tie` makes)."""
    terminal = problem.qmap.E[:, : problem.qmap.k]
    return bool(np.diff(terminal.tocsc().indptr).max(initial=0) > 1)
