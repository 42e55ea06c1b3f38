"""`fit`: one entry point for the three inverse-RL methods of SPEC section 3.

It builds the unknowns and the Q map once, runs the chosen method, optionally bounds every
unknown over the lp constraints (`--intervals`), and returns a `FitResult` with notes a
researcher should read: rewards the bound rather than the data decided, a loss minimiser
that is not unique, an optimiser that stopped early.
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np

from irl_core.demonstrations import Demonstrations
from irl_core.irl.intervals import reward_intervals
from irl_core.irl.loss import STALL_TOLERANCE, fit_loss
from irl_core.irl.lp import Progress, lp_constraints, solve_margin_lp
from irl_core.irl.maxent import fit_maxent
from irl_core.irl.qmap import RewardCells, build_qmap, build_unknowns
from irl_core.irl.result import BadInputError, FitResult, InfeasibleError

Method = Literal["lp", "loss", "maxent"]
METHODS: tuple[str, ...] = ("lp", "loss", "maxent")


def fit(
    demos: Demonstrations,
    *,
    method: Method = "lp",
    rmax: float = 1000.0,
    lam: float = 0.0,
    beta: float = 1.0,
    reward_cells: RewardCells = "special",
    tie: bool = False,
    intervals: bool = False,
    progress: Progress | None = None,
) -> FitResult:
    """Fit the state rewards that explain `demos` with `method`.

    `progress(stage, done, total)` hears of the lp's rounds and the interval LPs done.
    Raises `BadInputError` (no demonstrated steps; `InfeasibleError` when the lp has no
    solution) or `SolverError`.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, not {method!r}")
    if not rmax > 0:
        raise ValueError("rmax must be positive")
    if lam < 0:
        raise ValueError("lambda must be zero or more")
    if demos.counts.sum() <= 0:
        raise BadInputError("the recordings contain no steps: there is nothing to fit")
    start = time.perf_counter()
    mdp = demos.mdp
    unknowns = build_unknowns(mdp, reward_cells=reward_cells, tie=tie)
    qmap = build_qmap(mdp, unknowns)
    notes: list[str] = []
    status = "optimal"
    if unknowns.k == 0:
        notes.append("nothing to fit: every cell is ground, which --reward-cells special keeps at 0; "
                     "try --reward-cells all")
    constraints = None

    if method == "lp":
        constraints = lp_constraints(qmap, demos.most_frequent, rmax=rmax)
        solution = solve_margin_lp(constraints, lam=lam, progress=progress)
        theta, V = qmap.split(solution.x)
    elif method == "loss":
        solution = fit_loss(qmap, demos.policy, rmax=rmax, lam=lam)
        theta, V = qmap.split(solution.x)
        notes += solution.notes
        if solution.gap > STALL_TOLERANCE:
            status = "optimal_inaccurate"
    else:
        solution = fit_maxent(mdp, unknowns, demos.counts, beta=beta, rmax=rmax)
        theta, V = solution.theta, solution.V
        if not solution.converged:
            status = "not_converged"
            notes.append(f"maxent stopped before converging: {solution.message.lower()}")

    bounds = None
    if intervals:
        constraints = constraints or lp_constraints(qmap, demos.most_frequent, rmax=rmax)
        try:
            bounds, _ = reward_intervals(constraints, progress=progress)
        except InfeasibleError:
            notes.append(
                "intervals not computed: the most frequent actions are not optimal for any reward "
                "within ±rmax, so the lp constraints they come from are empty"
            )

    at_bound = [label for label, value in zip(unknowns.labels, theta) if abs(value) >= rmax * (1 - 1e-9)]
    if at_bound:
        notes.append(
            f"at ±rmax: {', '.join(at_bound)}; there the bound, not the demonstrations, set the value"
        )
    return FitResult(
        method=method,
        mdp=mdp,
        options={
            "rmax": rmax,
            "lambda": lam,
            "beta": beta,
            "reward_cells": reward_cells,
            "tie": tie,
            "intervals": intervals,
        },
        R_S=unknowns.state_rewards(theta),
        V=np.asarray(V, dtype=float),
        theta=np.asarray(theta, dtype=float),
        unknowns=unknowns,
        intervals=bounds,
        counts=demos.counts,
        demonstrations={"files": demos.files, "episodes": demos.episodes, "steps": demos.steps},
        status=status,
        elapsed_s=time.perf_counter() - start,
        notes=notes,
    )
