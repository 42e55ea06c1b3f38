"""How far the demonstrations pin each reward: the range of every unknown over the lp set.

For each unknown theta_j, the smallest and the largest value it takes over all (R_S, V)
that satisfy the simple IRL agent's constraints (`lp.lp_constraints`): 2 LPs per unknown.
An end at +-rmax means the demonstrations do not bound it on that side.

This is what carefulness buys (SPEC section 3). Without a carefulness choice an expert who
walks around the mud and an expert who walks around the cliff behave alike, and the two
intervals overlap; with it, the expert's extra care beside the cliff bounds the cliff's
reward far below the mud's.

All 2k LPs share one HiGHS model: only the cost vector changes between them, so each
solve starts from the previous optimal basis (still primal feasible) instead of from
scratch. (A large world's model is solved by the interior point method instead, which has no
basis to reuse: `lp.highs_lp`.)
"""

from __future__ import annotations

import numpy as np

from irl_core.irl.lp import LPConstraints, highs_lp


def reward_intervals(constraints: LPConstraints) -> tuple[np.ndarray, int]:
    """(k, 2) [min, max] of every unknown over the lp feasible set, and the simplex iterations.

    Raises `InfeasibleError` when the set is empty, `SolverError` if HiGHS fails.
    """
    k, n = constraints.qmap.k, constraints.qmap.n
    solver = highs_lp(constraints.A, constraints.row_lower, constraints.row_upper, constraints.lower, constraints.upper)
    intervals = np.empty((k, 2))
    cost = np.zeros(n)
    for j in range(k):
        for end, sign in ((0, 1.0), (1, -1.0)):
            cost[j] = sign
            _, objective = solver.minimise(cost)
            intervals[j, end] = sign * objective
        cost[j] = 0.0
    return intervals, solver.iterations
