"""The paper's simple IRL agent: the rewards under which the demonstrated policy is optimal.

Ng & Russell (2000), extended by Hanslope & Aitchison to rewards R(s, a) = R_S(s) + R_A(a)
with a known action cost. The demonstrated policy pi(s) is the most frequent action at s
(ties: lowest action index). The paper writes Q^pi through (I - gamma T^pi)^-1, which needs
pi everywhere; we keep the values V as variables (docs/fitting.md), so that

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
singular bases (docs/benchmarks.md, "How cost grows"), so every round is solved by the interior point
method without crossover instead; below it too, when a round of the dual simplex fails, the
LP is solved again that way. It keeps no basis, so each round starts from nothing, and
its answer is a point of (or near) the optimal face rather than a vertex: it comes with the
gap between its margin and the dual bound on the largest (`LPSolution.gap`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from irl_core.irl.lp.highs import INTERIOR, HighsModel, Options
from irl_core.irl.lp.margin import (
    LPConstraints,
    MarginLP,
    first_round_rows,
    margin_lp,
    seed_pairs,
    shares_terminal_unknowns,
)
from irl_core.irl.result import SolverError
from irl_core.worlds.planning import policy_evaluation

INFEASIBLE_MESSAGE = (
    "the demonstrations are not optimal for any reward within ±rmax; "
    "they may be noisy: try {method=loss}, or raise {rmax}"
)
# A row of the full LP violated by more than this (HiGHS's own feasibility tolerance) is added.
CUT_TOLERANCE = 1e-7

# progress(stage, done, total): stage "rounds" (total None) or "intervals" (total 2k LPs).
Progress = Callable[[str, int, "int | None"], None]


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
    Any start leads the simplex to the same optimum; this one is near it, so the first round
    takes a fraction of the iterations from HiGHS's own start (`bench.first_round_variants`
    policy-start against plain). The interval LPs do not use the like vertex of the lp set: it
    speeds up their first LP but slows the whole series (why was not found).
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
        # A failed round goes straight to the interior point method, not through `HighsModel`'s
        # cascade, which on the largest worlds costs more than the whole interior fit (`bench.bench_scaling`).
        run = RowGeneration(problem, options=margin_options(problem), retry=False)
        if not shares_terminal_unknowns(problem):
            # The policy's vertex halves a per-cell first round; a tied fit's guess of theta is far from
            # the optimum's, so it starts from HiGHS's own (`bench.first_round_variants` policy-start).
            start_from_policy(run)
        try:
            z = run.solve(progress=progress)
            return _solution(problem, z, run.model, rounds=run.rounds, first_rows=first_rows, interior=False,
                             limit=limit)
        except SolverError:
            simplex_failure = f"{run.model.report.status.replace('_', ' ')} in round {run.rounds + 1}"
            rounds, iterations = run.rounds + 1, run.model.iterations

    def counted(stage: str, done: int, total: int | None) -> None:  # rounds go on from the simplex's
        if progress is not None:
            progress(stage, rounds + done, total)

    run = RowGeneration(problem, options=INTERIOR)
    z = run.solve(progress=None if progress is None else counted)
    return _solution(problem, z, run.model, rounds=rounds + run.rounds, first_rows=first_rows, interior=True,
                     limit=limit, simplex_failure=simplex_failure, iterations=iterations)


# Dantzig pricing for the dual simplex: HiGHS's default (dual steepest edge) and devex spend more
# on their weights than they save on these rows; presolve stays on except for tied fits
# (`margin_options`). `bench.tied_first_round` measures each setting on a big world's first round.
MARGIN_OPTIONS: Options = {"simplex_dual_edge_weight_strategy": 0}


def margin_options(problem: MarginLP) -> Options:
    """The HiGHS options of a margin LP solved by the simplex from no basis: `MARGIN_OPTIONS`,
    and presolve off when a reward unknown is shared by several terminal cells (``tie=True``: one
    column in many of the rows V(s) = R_S(s)).

    Presolve stalls the first round of a tied fit and speeds up a per-cell one, by minutes on a
    64x64 world either way (`bench.tied_first_round` SIZE dual-dantzig[-nopresolve] [--untied]).
    """
    return {**MARGIN_OPTIONS, "presolve": "off"} if shares_terminal_unknowns(problem) else MARGIN_OPTIONS


# The first round's rows past which the margin LP is solved by the interior point method, round
# after round from no basis (`highs.INTERIOR`): beyond them the dual simplex is slower or fails its
# first round (docs/benchmarks.md#how-cost-grows, its "Past 80x80"; `bench.bench_scaling --stages lp_fit` measures both sides).
INTERIOR_ROWS = 30_000
# The same for a tied fit (one unknown for many terminal cells, solved by the simplex from HiGHS's
# own start without presolve, `margin_options`), whose simplex gives out sooner (the same bench's
# ``intervals_tied`` stage).
TIED_INTERIOR_ROWS = 25_000


def interior_rows(problem: MarginLP) -> int:
    """The first round's rows past which `problem` is solved by the interior point method."""
    return TIED_INTERIOR_ROWS if shares_terminal_unknowns(problem) else INTERIOR_ROWS


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

    def __init__(self, problem: MarginLP, *, options: Options,
                 after_rows: Options | None = None, warm_limit: float | None = None,
                 scratch: Options | None = None, retry: bool = True):
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

    def solve(self, *, progress: Progress | None = None, first: Options | None = None) -> np.ndarray:
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
        status=model.report.status, gap=model.report.gap, simplex_failure=simplex_failure,
    )
