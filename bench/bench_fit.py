"""Fitting speed against baselines run in the same process.

* lp: `careful fit`'s whole lp fit (unknowns, Q map, sparse assembly, row generation with
  HiGHS) against scipy.optimize.linprog(method="highs") on the whole slack-form LP, assembled
  beforehand (only the solve is timed), and against the same LP stated in cvxpy and solved
  with HiGHS.
  Target: within 2x of linprog. On `paper` from 100 optimal episodes.
* intervals: the 2k interval LPs (one explicit dual re-solved from its last basis) against
  one lp fit. Target: within 10x. On `mud` from 100 optimal episodes.
* loss: the exact outer approximation (all stages: minimum, smallest ||R_S||_1, uniqueness)
  against one cvxpy + Clarabel solve of the literal problem, for information.

Run: .venv/bin/python bench/bench_fit.py
"""

from __future__ import annotations

import warnings
from functools import partial

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

from bench.timing import best_of
from irl_core.irl import fit
from irl_core.irl.intervals.identified import reward_intervals
from irl_core.irl.loss.model import loss_constraints, loss_problem
from irl_core.irl.loss.solve import fit_loss
from irl_core.irl.lp.margin import lp_constraints, margin_lp
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.players.experts import boltzmann_policy, optimal_policy, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def demonstrations(name: str, *, episodes: int, seed: int, beta: float | None = None) -> Demonstrations:
    mdp = build_mdp(BUILTIN_WORLDS[name])
    policy = optimal_policy(mdp) if beta is None else boltzmann_policy(mdp, beta=beta)
    result = rollouts(mdp, policy, episodes=episodes, seed=seed)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    return Demonstrations(mdp=mdp, counts=counts, files=1, episodes=episodes, steps=int(counts.sum()))


def linprog_form(problem):
    """The margin LP as linprog's A_ub, b_ub, A_eq, b_eq, bounds."""
    eq = problem.row_lower == problem.row_upper
    upper = np.isfinite(problem.row_upper) & ~eq
    lower = np.isfinite(problem.row_lower) & ~eq
    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
              for lo, hi in zip(problem.lower, problem.upper)]
    A_ub = sp.vstack([problem.A[upper], -problem.A[lower]], format="csr")
    b_ub = np.concatenate([problem.row_upper[upper], -problem.row_lower[lower]])
    return A_ub, b_ub, problem.A[eq], problem.row_lower[eq], bounds


def cvxpy_solve(problem) -> float:
    A_ub, b_ub, A_eq, b_eq, _ = linprog_form(problem)
    z = cp.Variable(problem.A.shape[1])
    finite = np.isfinite(problem.lower)
    constraints = [A_ub @ z <= b_ub, A_eq @ z == b_eq,
                   z[finite] >= problem.lower[finite], z[finite] <= problem.upper[finite]]
    model = cp.Problem(cp.Minimize(problem.cost @ z), constraints)
    model.solve(solver=cp.HIGHS)
    return model.value


def bench_lp() -> None:
    print("lp from 100 optimal episodes: careful's whole fit and cvxpy against linprog's solve alone")
    print(f"  {'world':<13} {'LP size':>16} {'careful ms':>11} {'linprog ms':>11} {'cvxpy ms':>9} "
          f"{'careful/linprog':>16} {'cvxpy/linprog':>14}")
    for name in ("paper", "mud", "paper-simple"):
        demos = demonstrations(name, episodes=100, seed=0)
        qmap = build_qmap(demos.mdp, build_unknowns(demos.mdp))
        problem = margin_lp(lp_constraints(qmap, demos.most_frequent, rmax=1000.0)).full()
        A_ub, b_ub, A_eq, b_eq, bounds = linprog_form(problem)

        baseline = partial(linprog, problem.cost, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds,
                           method="highs")

        assert abs(baseline().fun - cvxpy_solve(problem)) < 1e-6
        ours = best_of(20, partial(fit, demos, method="lp"))
        reference = best_of(20, baseline)
        through_cvxpy = best_of(10, partial(cvxpy_solve, problem))
        size = f"{problem.A.shape[0]}x{problem.A.shape[1]}"
        print(f"  {name:<13} {size:>16} {ours * 1e3:>11.1f} {reference * 1e3:>11.1f} {through_cvxpy * 1e3:>9.1f} "
              f"{ours / reference:>16.2f} {through_cvxpy / reference:>14.2f}")
    print("  target: careful/linprog <= 2 on paper")


def bench_intervals() -> None:
    demos = demonstrations("mud", episodes=100, seed=0)
    constraints = lp_constraints(build_qmap(demos.mdp, build_unknowns(demos.mdp)), demos.most_frequent, rmax=1000.0)
    one_fit = best_of(20, lambda: fit(demos, method="lp"))
    intervals = best_of(20, lambda: reward_intervals(constraints))
    with_intervals = best_of(20, lambda: fit(demos, method="lp", intervals=True))
    k = constraints.qmap.k
    print(f"intervals on mud, 100 optimal episodes ({k} unknowns, {2 * k} LPs):")
    print(f"  one lp fit {one_fit * 1e3:.1f} ms; the {2 * k} interval LPs {intervals * 1e3:.1f} ms; "
          f"fit with --intervals {with_intervals * 1e3:.1f} ms")
    print(f"  intervals / one fit = {intervals / one_fit:.2f} (target <= 10)")


def bench_loss() -> None:
    # Seed 3: an instance Clarabel solves (it stops with "insufficient progress" on some).
    demos = demonstrations("paper", episodes=10, seed=3, beta=1.0)
    qmap = build_qmap(demos.mdp, build_unknowns(demos.mdp))
    ours = best_of(5, lambda: fit_loss(qmap, demos.policy, rmax=1000.0))

    def clarabel():
        problem, _ = loss_problem(loss_constraints(qmap, demos.policy, rmax=1000.0))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem.solve(solver=cp.CLARABEL)
        return problem

    conic = best_of(5, clarabel)
    print("loss on paper, 10 Boltzmann (beta 1) episodes:")
    print(f"  outer approximation, all stages {ours * 1e3:.1f} ms; cvxpy + Clarabel, minimum only "
          f"{conic * 1e3:.1f} ms (status {clarabel().status}); ratio {ours / conic:.2f}")


def main() -> None:
    bench_lp()
    bench_intervals()
    bench_loss()


if __name__ == "__main__":
    main()
