"""The paper's simple IRL agent: the rewards under which the demonstrated policy is optimal.

Ng & Russell (2000), extended by Hanslope & Aitchison to rewards R(s, a) = R_S(s) + R_A(a)
with a known action cost. The demonstrated policy pi(s) is the most frequent action at s
(ties: lowest action index). The paper writes Q^pi through (I - gamma T^pi)^-1, which needs
pi everywhere; we keep the values V as variables (README "Fitting a reward"), so that

    V(s) >= Q(s, a)             every non-terminal s, every a      (no action beats V)
    V(s)  = Q(s, pi(s))         every demonstrated s               (pi(s) attains it)
    V(s)  = R_S(s)              every terminal cell;  V(exit) = 0
    |R_S| <= rmax,  |V| <= (rmax + max |R_A|) / (1 - gamma)

with Q(s, a) = R_S(s) + R_A(a) + gamma sum_s' P(s'|s, a) V(s') affine in x = [theta; V]
(`qmap`). When every non-terminal state is demonstrated, V = V^pi and this is exactly the
paper's LP; at a state never demonstrated it assumes only that the expert would act
optimally there. The value bound is one no genuine value function exceeds; it only closes
rays along which an unvisited state's value (bounded only from below) could grow.

Among the feasible rewards the agent maximises the paper's margin (its equation 1),

    sum over demonstrated s of [V(s) - max_{a != pi(s)} Q(s, a)]  -  lambda ||R_S||_1.

Slack form. The paper's epigraph (t_s >= Q(s, a), a != pi(s)) repeats the rows V(s) >= Q(s, a)
at demonstrated states. Writing instead

    V(s) - Q(s, a) >= m_s  (a != pi(s)),   m_s >= 0,   margin = sum_s m_s

is exactly equivalent (at an optimum m_s = V(s) - max_{a != pi(s)} Q(s, a), and m_s >= 0 is
V(s) >= Q(s, a)), with one row per pair instead of two: 225,912 rows instead of 376,557 on a
64x64 world. With lambda > 0, u >= |theta| adds 2k rows.

Row generation. At the optimum only about one row V(s) - Q(s, a) >= m_s per state is tight
(985 of 54,753 on a 32x32 world), so one live HiGHS model starts from a few rows per state
and each round adds every state's most violated row, solved by the dual simplex from the last
basis; it stops when no row of the full LP is violated, so the answer is the full LP's. The
seed matters: at a demonstrated state the demonstrated direction at carefulness +-1 and the
other directions at the demonstrated carefulness (the near rivals), elsewhere all four
directions at carefulness 1. Seeding only the equalities leaves the first rounds wild
(objective -1.1e8 on a 64x64 world) and takes many more rounds.

The first round starts from a vertex built from a policy (`start_from_policy`): each reward
unknown at the bound the demonstrations suggest, V the values of pi with the best actions
elsewhere. HiGHS's own start (all rows loose) took four times the simplex iterations on a
64x64 world. Tied fits keep HiGHS's start, which is far better for them (`solve_margin_lp`).

Big worlds. Past `INTERIOR_ROWS` rows in the first round the dual simplex meets nearly
singular bases (README "How cost grows"), so every round is solved by the interior point
method without crossover instead; below it too, when a round of the dual simplex fails, the
LP is solved again that way. It keeps no basis, so each round starts from nothing, and
its answer is a point of (or near) the optimal face rather than a vertex: it comes with the
gap between its margin and the dual bound on the largest (`LPSolution.gap`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.irl.highs import INTERIOR, HighsModel, LinearProgram, linear_program
from irl_core.irl.qmap import QMap
from irl_core.irl.result import SolverError
from irl_core.planning import policy_evaluation

INFEASIBLE_MESSAGE = (
    "the demonstrations are not optimal for any reward within ±rmax; "
    "they may be noisy: try --method loss, or raise --rmax"
)
# A row of the full LP violated by more than this (HiGHS's own feasibility tolerance) is added.
CUT_TOLERANCE = 1e-7

# progress(stage, done, total): stage "rounds" (total None) or "intervals" (total 2k LPs).
Progress = Callable[[str, int, "int | None"], None]


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
    S, A = qmap.mdp.n_states, qmap.mdp.n_actions
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


def aimed_unknowns(problem: MarginLP) -> np.ndarray:
    """(k,) True for the unknowns of terminal cells some demonstrated action is aimed at (the
    cell is that action's most likely outcome): where the expert ends on purpose."""
    qmap = problem.qmap
    mdp, shown = qmap.mdp, problem.demonstrated
    outcomes = mdp.P[shown * mdp.n_actions + problem.policy[shown]]
    aimed = np.zeros(mdp.n_states, dtype=bool)
    aimed[np.asarray(outcomes.argmax(axis=1)).ravel()] = True
    return np.asarray(qmap.unknowns.basis[aimed & mdp.terminal].sum(axis=0)).ravel() > 0


def policy_vertex(problem: MarginLP, *, improvements: int = 10) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A vertex of the margin LP to start the first round from: theta (k,), V (S,) and a policy (S,).

    theta is +rmax (the LP's bound on theta) for `aimed_unknowns` and -rmax for the others. The policy is pi at the
    demonstrated states and elsewhere the best action for the values of (theta, the policy),
    after `improvements` rounds of policy iteration (a start need not be optimal; ties can make
    policy iteration cycle on big worlds).
    """
    qmap = problem.qmap
    mdp = qmap.mdp
    rmax = float(problem.base.upper[: qmap.k].max(initial=1.0))
    theta = np.where(aimed_unknowns(problem), rmax, -rmax)
    R_S = qmap.unknowns.state_rewards(theta)
    free = mdp.nonterminal & (problem.policy < 0)
    policy = np.maximum(problem.policy, 0)  # any action at terminal cells and the exit: all lead out
    for _ in range(improvements + 1):
        V = policy_evaluation(mdp, policy, R_S=R_S)
        improved = np.where(free, qmap.q(np.concatenate([theta, V])).argmax(axis=1), policy)
        if np.array_equal(improved, policy):
            break
        policy = improved
    return theta, V, policy


def start_from_policy(run: RowGeneration) -> None:
    """Give `run`'s model the basis of `policy_vertex` before its first solve.

    Basic: every V, every m_s (and u); theta nonbasic at its bound. Tight (nonbasic) rows: the
    equalities, at an undemonstrated state the row of the policy's action, at a demonstrated
    state the row of its best rival (whose slack m_s is), and u >= |theta| on theta's side.
    Any start leads the simplex to the same optimum; this one is near it: on a 64x64 world the
    fit's first round took 3,831 simplex iterations instead of 15,185 from HiGHS's own start.
    (The interval LPs do not use it: from the like vertex of the lp set a 64x64 world's first
    interval LP took 1.8 s instead of 15 to 21 s, but its 126 LPs took 491 s in all against
    188 s; why was not found.)
    """
    problem = run.problem
    qmap = problem.qmap
    mdp, shown = qmap.mdp, problem.demonstrated
    theta, V, policy = policy_vertex(problem)
    tight = np.zeros_like(problem.rivals)
    free = np.flatnonzero(mdp.nonterminal & (problem.policy < 0))
    tight[free, policy[free]] = True
    rival_q = np.where(problem.rivals, qmap.q(np.concatenate([theta, V])), -np.inf)
    tight[shown, rival_q[shown].argmax(axis=1)] = True
    run.add(tight & ~run.in_model)
    n_u = problem.base.shape[1] - qmap.n - shown.size
    columns = np.concatenate([np.where(theta > 0, 1, -1), np.zeros(mdp.n_states + shown.size + n_u, dtype=int)])
    base_rows = [np.full(qmap.E.shape[0] + shown.size, -1)]
    if n_u:  # theta - u <= 0 is tight at theta = +rmax, -theta - u <= 0 at -rmax
        base_rows += [np.where(theta > 0, 1, 0), np.where(theta > 0, 0, 1)]
    family = np.where(tight[run.pairs[:, 0], run.pairs[:, 1]], -1, 0)
    run.model.set_basis(columns, np.concatenate([*base_rows, family]))


@dataclass(frozen=True)
class LPSolution:
    """x = [theta; V] of the margin LP's optimum, its margin sum and the work it took.

    Attributes:
        rounds: LP solves (1 without row generation).
        rows: rows of the last model.
        iterations: HiGHS's simplex (and interior point) iterations over all rounds.
        first_rows: rows of the first round (`first_round_rows`).
        interior: whether the interior point method solved it.
        interior_rows: the first round's rows past which it would have been (`interior_rows`;
            None when the whole LP was solved).
        status: HiGHS's word for the last round's answer, in ours: "optimal", or
            "optimal_inaccurate" for an interior point answer HiGHS did not call optimal.
        gap: the last round's gap between the margin and the dual bound on it, relative: 0 for
            a vertex (optimal within HiGHS's tolerances), else the interior point method's
            (`highs.INTERIOR`).
        simplex_failure: how the dual simplex failed ("solve error in round 1") when it was
            given up for the interior point method, else None.
    """

    x: np.ndarray
    margin: float
    iterations: int
    rounds: int
    rows: int
    first_rows: int
    interior: bool = False
    interior_rows: int | None = None
    status: str = "optimal"
    gap: float = 0.0
    simplex_failure: str | None = None


def solve_margin_lp(
    constraints: LPConstraints,
    *,
    lam: float = 0.0,
    generate_rows: bool = True,
    interior: bool | None = None,
    progress: Progress | None = None,
) -> LPSolution:
    """Solve the margin LP by row generation (or, with `generate_rows=False`, whole), every
    round by the dual simplex or, with `interior`, by the interior point method (None: when the
    first round has over `interior_rows` rows). When a round of the dual simplex fails, the LP
    is solved again by the interior point method, from nothing.

    Raises `InfeasibleError` or `SolverError`.
    """
    problem = margin_lp(constraints, lam=lam)
    if not generate_rows:
        model = HighsModel(problem.full())
        z, _ = model.minimise(infeasible_message=INFEASIBLE_MESSAGE)
        return _solution(problem, z, model, rounds=1, first_rows=model.n_row, interior=False)
    first_rows, limit = first_round_rows(problem), interior_rows(problem)
    if interior is None:
        interior = first_rows > limit
    simplex_failure = None
    rounds = iterations = 0
    if not interior:
        # A failed round is not retried by the other solvers (`HighsModel`'s cascade): on an
        # 84x84 world the dual simplex failed its first round in 70 s ("solve error"), and with
        # the cascade the fit was not done in 8.5 CPU minutes; by the interior point method 93 s.
        run = RowGeneration(problem, options=margin_options(problem), retry=False)
        if not shares_terminal_unknowns(problem):
            # Measured on the 64x64 world: per cell 5.3 s from this start against 10.3 s; tied
            # (theta's guess then far from the optimum's) 422 s against 8.8 s from HiGHS's own.
            start_from_policy(run)
        try:
            z = run.solve(progress=progress)
            return _solution(problem, z, run.model, rounds=run.rounds, first_rows=first_rows, interior=False,
                             limit=limit)
        except SolverError:
            simplex_failure = f"{run.model.last.status.replace('_', ' ')} in round {run.rounds + 1}"
            rounds, iterations = run.rounds + 1, run.model.iterations

    def counted(stage: str, done: int, total: int | None) -> None:  # rounds go on from the simplex's
        progress(stage, rounds + done, total)

    run = RowGeneration(problem, options=INTERIOR)
    z = run.solve(progress=None if progress is None else counted)
    return _solution(problem, z, run.model, rounds=rounds + run.rounds, first_rows=first_rows, interior=True,
                     limit=limit, simplex_failure=simplex_failure, iterations=iterations)


# Dantzig pricing for the dual simplex: HiGHS's default, dual steepest edge, spends more time
# on its weights than it saves here (a 64x64 world's first round: 23 s against over 150 s;
# devex: over 6 minutes). HiGHS's presolve stays on (`margin_options`): without it a 64x64
# world's fit took over 4 minutes instead of 16 s.
MARGIN_OPTIONS = {"simplex_dual_edge_weight_strategy": 0}


def margin_options(problem: MarginLP) -> dict[str, object]:
    """The HiGHS options of a margin LP solved by the simplex from no basis: `MARGIN_OPTIONS`,
    and presolve off when a reward unknown is shared by several terminal cells (`--tie`: one
    column in many of the rows V(s) = R_S(s)).

    Measured on the 64x64 world's first round, one solve at a time (`bench.tied_first_round`):
    with a shared unknown (2 columns, 62 and 1 cells) not solved in 60 s with presolve (over 12
    minutes in an earlier session), 8.8 s without; with one unknown per cell (63 columns) 9.0 s
    with presolve, not solved in 60 s without (over 4 minutes in the earlier session).
    """
    return {**MARGIN_OPTIONS, "presolve": "off"} if shares_terminal_unknowns(problem) else MARGIN_OPTIONS


# The first round's rows past which the margin LP is solved by the interior point method,
# round after round from no basis (`highs.INTERIOR`). The generated cliff worlds' fits by the
# dual simplex, one run each (README "How cost grows"): 64x64 (19,052 rows) 5 to 9 s; 76x76
# (26,483) its first round in 19 s; 80x80 (29,268) 15 s against 61 s by the interior point
# method; 84x84 (32,019) a solve error in its first round after 70 s, against 93 s for the whole
# fit; 88x88 (35,281) not through its first round in 8.5 CPU minutes, against 103 s; 96x96
# (41,232) not in 6.6 CPU minutes; 128x128 (71,201) a solve error after 20 minutes, against
# 555 to 685 s.
INTERIOR_ROWS = 30_000
# The same for a tied fit (one unknown for many terminal cells, solved by the simplex from HiGHS's
# own start without presolve, `margin_options`), whose simplex gives out sooner. Tied fits of the
# same worlds, one run each at load 2 to 3: 72x72 (23,934 rows) 21 s by the simplex; 76x76
# (26,483) and 80x80 (29,268) the simplex failed its first round after about 4 minutes ("unknown",
# "solve error"); 84x84 (32,019) 68 s by the interior point method.
TIED_INTERIOR_ROWS = 25_000


def interior_rows(problem: MarginLP) -> int:
    """The first round's rows past which `problem` is solved by the interior point method."""
    return TIED_INTERIOR_ROWS if shares_terminal_unknowns(problem) else INTERIOR_ROWS


def first_round_rows(problem: MarginLP) -> int:
    """The rows of the margin LP's first round: the base rows and the seed (`seed_pairs`)."""
    return problem.base.shape[0] + int(seed_pairs(problem).sum())


def shares_terminal_unknowns(problem: MarginLP) -> bool:
    """Whether one reward unknown stands for several terminal cells (what `--tie` makes)."""
    terminal = problem.qmap.E[:, : problem.qmap.k]
    return bool(np.diff(terminal.tocsc().indptr).max(initial=0) > 1)


class RowGeneration:
    """The margin LP solved by row generation in one live HiGHS model (see the module docstring).

    `options`, `warm_limit`, `scratch` and `retry` are the model's (`HighsModel`); `after_rows` are the
    HiGHS options of the solves after new rows (default: the model's).

    Attributes:
        model: the HiGHS model, holding the base rows and the family rows in `in_model`.
        in_model: (S, A) the family rows added so far.
        pairs: (r, 2) the (state, action) of each family row, in the model's order (after the base rows).
        rounds: LPs solved.
    """

    def __init__(self, problem: MarginLP, *, options: dict[str, object],
                 after_rows: dict[str, object] | None = None, warm_limit: float | None = None,
                 scratch: dict[str, object] | None = None, retry: bool = True):
        self.problem = problem
        self.in_model = np.zeros_like(problem.rivals)
        self.pairs = np.zeros((0, 2), dtype=np.int64)
        self.after_rows = after_rows
        self.model = HighsModel(problem.base, options=options, warm_limit=warm_limit, scratch=scratch, retry=retry)
        self.add(seed_pairs(problem))
        self.rounds = 0

    def add(self, pairs: np.ndarray) -> None:
        """Add the family rows of the (S, A) `pairs` to the model."""
        states, actions = np.nonzero(pairs)
        rows, q0 = self.problem.rows(states, actions)
        self.model.add_rows(rows, q0, np.full(q0.size, np.inf))
        self.in_model |= pairs
        self.pairs = np.concatenate([self.pairs, np.column_stack([states, actions])])

    def solve(self, *, progress: Progress | None = None, first: dict[str, object] | None = None) -> np.ndarray:
        """z at the full LP's optimum for the model's current cost, the first LP solved with the
        HiGHS options `first`, the later ones (after new rows) with `after_rows` (else the model's own).

        Raises `InfeasibleError` or `SolverError`.
        """
        problem = self.problem
        options = first
        while True:  # each round adds rows of a finite family, so it ends
            z, _ = self.model.minimise(infeasible_message=INFEASIBLE_MESSAGE, options=options)
            options = self.after_rows
            self.rounds += 1
            if progress is not None:
                progress("rounds", self.rounds, None)
            slack = np.where(problem.rivals & ~self.in_model, problem.slacks(z), np.inf)
            worst = slack.argmin(axis=1)
            states = np.flatnonzero(slack[np.arange(slack.shape[0]), worst] < -CUT_TOLERANCE)
            if states.size == 0:
                return z
            add = np.zeros_like(self.in_model)
            add[states, worst[states]] = True
            self.add(add)


def _solution(problem: MarginLP, z: np.ndarray, model: HighsModel, *, rounds: int, first_rows: int,
              interior: bool, limit: int | None = None, simplex_failure: str | None = None,
              iterations: int = 0) -> LPSolution:
    """The answer `z` of `model`'s last solve; `iterations` of a route given up before it are added."""
    n, n_d = problem.qmap.n, problem.demonstrated.size
    return LPSolution(
        x=z[:n], margin=float(z[n : n + n_d].sum()), iterations=iterations + model.iterations, rounds=rounds,
        rows=model.n_row, first_rows=first_rows, interior=interior, interior_rows=limit,
        status=model.last.status, gap=model.last.gap, simplex_failure=simplex_failure,
    )
