"""How far the demonstrations pin each reward: the range of every unknown over the lp set.

For each unknown theta_j, the smallest and the largest value it takes over all (R_S, V)
that satisfy the simple IRL agent's constraints (`lp.lp_constraints`): 2 LPs per unknown.
An end at +-rmax means the demonstrations do not bound it on that side.

This is what carefulness buys (SPEC section 3). Without a carefulness choice an expert who
walks around the mud and an expert who walks around the cliff behave alike, and the two
intervals overlap; with it, the expert's extra care beside the cliff bounds the cliff's
reward far below the mud's.

The 2k LPs differ only in their cost (+-e_j), and they are solved through their explicit
dual. For min c @ x subject to G x >= g (y >= 0), H x <= h (y <= 0), F x = f (y free), where
the rows of the lp set and the bounds on x make up G, H and F, the dual is

    max g @ y_G + h @ y_H + f @ y_F   subject to   G^T y_G + H^T y_H + F^T y_F = c,

with one row per primal variable (k + S of them, against S * A primal rows) and c only on
the right-hand side. A new end is then new row bounds: the last optimal basis stays dual
feasible and the dual simplex starts from it, a few pivots per LP. (Changing the primal's
cost instead left 4 of 62 LPs of a 32x32 world unsolved, "unknown", and took 24x longer.)
The dual is always feasible (the bound columns alone can make up any c), so a primal with
no feasible point shows as an unbounded dual.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from irl_core.irl.highs import HighsModel, LinearProgram, linear_program
from irl_core.irl.lp import INFEASIBLE_MESSAGE, LPConstraints, Progress
from irl_core.irl.result import InfeasibleError, SolverError


def explicit_dual(program: LinearProgram) -> LinearProgram:
    """The dual of `program` as a minimisation, its cost as row bounds (n rows, one per primal column).

    The dual's optimum is minus the primal's. Its columns: one free column per equality row or
    fixed variable, one y >= 0 per finite lower side and one y <= 0 per finite upper side of
    every other row and bound.
    """
    n = program.shape[1]
    G = sp.vstack([program.A, sp.identity(n, format="csr")], format="csr")
    low = np.concatenate([program.row_lower, program.lower])
    high = np.concatenate([program.row_upper, program.upper])
    equal = low == high
    below = ~equal & np.isfinite(low)
    above = ~equal & np.isfinite(high)
    columns = [equal, below, above]
    return linear_program(
        sp.hstack([G[rows].T for rows in columns], format="csr"),
        program.cost,
        program.cost,
        np.concatenate([np.full(equal.sum(), -np.inf), np.zeros(below.sum()), np.full(above.sum(), -np.inf)]),
        np.concatenate([np.full(equal.sum(), np.inf), np.full(below.sum(), np.inf), np.zeros(above.sum())]),
        -np.concatenate([low[equal], low[below], high[above]]),
    )


def reward_intervals(constraints: LPConstraints, *, progress: Progress | None = None) -> tuple[np.ndarray, int]:
    """(k, 2) [min, max] of every unknown over the lp feasible set, and the simplex iterations.

    `progress("intervals", done, 2k)` is called after each LP.
    Raises `InfeasibleError` when the set is empty, `SolverError` if HiGHS fails.
    """
    k = constraints.qmap.k
    model = HighsModel(explicit_dual(constraints.program))
    intervals = np.empty((k, 2))
    rows = np.arange(k)
    for j in range(k):
        for end, sign in ((0, 1.0), (1, -1.0)):
            # Only row j of the dual's right-hand side (the primal's cost) changes.
            c = np.where(rows == j, sign, 0.0)
            model.set_row_bounds(rows, c, c)
            _, report = model.solve()
            if report.kind == "unbounded":
                raise InfeasibleError(INFEASIBLE_MESSAGE)
            if report.kind != "answer":
                raise SolverError(f"an interval LP was left without an answer by HiGHS ({report.solver}: {report.status})")
            intervals[j, end] = -sign * report.objective
            if progress is not None:
                progress("intervals", 2 * j + end + 1, 2 * k)
    return intervals, model.iterations
