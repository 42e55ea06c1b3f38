"""How far the demonstrations pin each reward: the range of every unknown over the lp set.

For each unknown theta_j, the smallest and the largest value it takes over all (R_S, V)
that satisfy the simple IRL agent's constraints (`margin.lp_constraints`): 2 LPs per unknown.
An end at +-rmax means the demonstrations do not bound it on that side.

This is what carefulness buys (docs/fitting.md). Without a carefulness choice an expert who
walks around the mud and an expert who walks around the cliff behave alike, and the two
intervals overlap; with it, the expert's extra care beside the cliff bounds the cliff's
reward far below the mud's.

The 2k LPs differ only in their cost (+-e_j) and are solved by the lp's row generation
(`lp.RowGeneration`) in one live HiGHS model: the margin LP with every m_s fixed at 0, so that
its family rows read V(s) >= Q(s, a). A new cost leaves the last basis primal feasible and the
primal simplex starts from it (`AFTER_NEW_COST`); the rows any LP needed stay for the next
ones, so after the first few LPs hardly any are added. That is faster than the explicit dual of
the whole LP (one row per primal variable, a new cost being a new right-hand side), whose columns
grow with the whole LP's rows; `bench/bench_fit.py` times the intervals against one fit.

Past `lp.INTERIOR_ROWS` (`interior=True`) each LP is solved as the big worlds' fit is, by the
interior point method round after round from nothing, and its end is moved out by the LP's gap
to the dual bound (`highs.SolveReport.gap`): a point that is not quite optimal would otherwise
give an interval inside the set. The ends are then outer bounds of the set (up to HiGHS's
tolerances), as near to it as the gaps.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from irl_core.irl.lp.highs import INTERIOR, LinearProgram, Options
from irl_core.irl.lp.margin import LPConstraints, margin_lp
from irl_core.irl.lp.solve import Progress, RowGeneration, margin_options

# The first LP starts from no basis and is solved as the margin is (`lp.margin_options`: the
# dual simplex with Dantzig pricing), and so is any LP retried from scratch. After a new cost
# the last basis stays primal feasible: the primal simplex starts from it; after new rows it
# stays dual feasible: the dual simplex. Both with HiGHS's own pricing (steepest edge or
# devex), kept as the model's so that its edge weights carry over from one solve to the next
# (switching pricing at every solve is several times slower; Dantzig's pricing, or HiGHS's own
# choice of simplex, leaves some of a big world's LPs unsolved for minutes). Some bases there
# are nearly singular: a solve from a basis is given up after WARM_LIMIT seconds (several times
# a normal one on a 64x64 world) and retried by the other simplex from the same basis, then from
# scratch (`highs.HighsModel.solve`), which answers where the stuck simplex would not
# (`bench.bench_scaling --stages intervals_cells` measures the intervals on big worlds).
INTERVAL_OPTIONS: Options = {}
AFTER_NEW_COST = {"simplex_strategy": 4}
AFTER_NEW_ROWS = {"simplex_strategy": 1}
WARM_LIMIT = 10.0


def reward_intervals(constraints: LPConstraints, *, interior: bool = False,
                     progress: Progress | None = None) -> tuple[np.ndarray, int]:
    """(k, 2) [min, max] of every unknown over the lp feasible set, and the solvers' iterations;
    with `interior`, by the interior point method, each end moved out by its LP's gap.

    `progress("intervals", done, 2k)` is called after each LP.
    Raises `InfeasibleError` when the set is empty, `SolverError` if HiGHS fails.
    """
    k, n = constraints.qmap.k, constraints.qmap.n
    problem = margin_lp(constraints)
    base = problem.base
    upper = base.upper.copy()
    upper[n:] = 0.0  # m_s = 0: the family rows are V(s) >= Q(s, a), the lp set itself
    feasible = LinearProgram(base.A, base.row_lower, base.row_upper, base.lower, upper, np.zeros(base.shape[1]))
    feasible_problem = dataclasses.replace(problem, base=feasible)
    from_scratch = margin_options(problem)
    if interior:
        run = RowGeneration(feasible_problem, options=INTERIOR)
    else:
        run = RowGeneration(feasible_problem, options=INTERVAL_OPTIONS, after_rows=AFTER_NEW_ROWS,
                            warm_limit=WARM_LIMIT, scratch=from_scratch)
    intervals = np.empty((k, 2))
    cost = np.zeros(base.shape[1])
    for done, (j, end) in enumerate(interval_order(k), start=1):
        sign = 1.0 if end == 0 else -1.0
        cost[j] = sign
        run.model.set_cost(cost)
        if interior:
            # The LP's optimum lies between its dual bound and the point's cost sign * theta_j.
            run.solve()
            report = run.model.report
            outer = sign * (report.objective - report.gap * max(abs(report.objective), 1.0))
            intervals[j, end] = np.clip(outer, base.lower[j], base.upper[j])
        else:
            intervals[j, end] = run.solve(first=AFTER_NEW_COST if done > 1 else from_scratch)[j]
        cost[j] = 0.0
        if progress is not None:
            progress("intervals", done, 2 * k)
    return intervals, run.model.iterations


def interval_order(k: int) -> list[tuple[int, int]]:
    """The 2k LPs as (unknown, end), end 0 the lower: every lower end in the unknowns' order,
    then every upper end back again.

    Unknowns are numbered in row-major cell order, so consecutive LPs move the cost to a
    neighbouring cell; only one LP moves a cell from one end to the other. (On a 32x32 world
    the two orders took about as many simplex iterations, 3,523 against 3,640 alternating
    ends: what made the 64x64 LPs finish was the simplex chosen, see `INTERVAL_OPTIONS`.)
    """
    return [(j, 0) for j in range(k)] + [(j, 1) for j in reversed(range(k))]
