"""How far the demonstrations pin each reward: the range of every unknown over the lp set.

For each unknown theta_j, the smallest and the largest value it takes over all (R_S, V)
that satisfy the simple IRL agent's constraints (`lp.lp_constraints`): 2 LPs per unknown.
An end at +-rmax means the demonstrations do not bound it on that side.

This is what carefulness buys (SPEC section 3). Without a carefulness choice an expert who
walks around the mud and an expert who walks around the cliff behave alike, and the two
intervals overlap; with it, the expert's extra care beside the cliff bounds the cliff's
reward far below the mud's.

The 2k LPs differ only in their cost (+-e_j) and are solved by the lp's row generation
(`lp.RowGeneration`) in one live HiGHS model: the margin LP with every m_s fixed at 0, so that
its family rows read V(s) >= Q(s, a). A new cost leaves the last basis primal feasible and the
primal simplex starts from it; the rows any LP needed stay for the next ones, so after the
first few LPs hardly any are added. Measured against the explicit dual of the whole LP (one
row per primal variable, a new cost being a new right-hand side, solved from the last basis):
2x faster on a 32x32 world's 62 LPs, and 37 s against over 4 minutes for a 64x64 world's 4
tied LPs, where the dual has 230,000 columns.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from irl_core.irl.highs import LinearProgram
from irl_core.irl.lp import LPConstraints, Progress, RowGeneration, margin_lp

# HiGHS chooses the simplex (primal after a new cost, dual after new rows); Dantzig pricing
# for both, as for the margin (`lp.MARGIN_OPTIONS`).
INTERVAL_OPTIONS = {
    "simplex_strategy": 0,
    "simplex_dual_edge_weight_strategy": 0,
    "simplex_primal_edge_weight_strategy": 0,
}


def reward_intervals(constraints: LPConstraints, *, progress: Progress | None = None) -> tuple[np.ndarray, int]:
    """(k, 2) [min, max] of every unknown over the lp feasible set, and the simplex iterations.

    `progress("intervals", done, 2k)` is called after each LP.
    Raises `InfeasibleError` when the set is empty, `SolverError` if HiGHS fails.
    """
    k, n = constraints.qmap.k, constraints.qmap.n
    problem = margin_lp(constraints)
    base = problem.base
    upper = base.upper.copy()
    upper[n:] = 0.0  # m_s = 0: the family rows are V(s) >= Q(s, a), the lp set itself
    feasible = LinearProgram(base.A, base.row_lower, base.row_upper, base.lower, upper, np.zeros(base.shape[1]))
    run = RowGeneration(dataclasses.replace(problem, base=feasible), options=INTERVAL_OPTIONS)
    intervals = np.empty((k, 2))
    cost = np.zeros(base.shape[1])
    for j in range(k):
        for end, sign in ((0, 1.0), (1, -1.0)):
            cost[j] = sign
            run.model.set_cost(cost)
            intervals[j, end] = run.solve()[j]
            if progress is not None:
                progress("intervals", 2 * j + end + 1, 2 * k)
        cost[j] = 0.0
    return intervals, run.model.iterations
