"""How cost grows with the world: time, peak memory and effort per stage on generated cliff worlds.

Each (size, stage) runs in a fresh process, so its peak resident memory is its own. In that
process value iteration on the same world is timed first (best of 3) and every stage is also
given as a multiple of it ("VI"), the ratio to compare across a shared, noisy machine.
The growth exponent k fits time ~ states^k over the sizes.

Run: .venv/bin/python -m bench.bench_scaling [--sizes 4x6,16x16,32x32,64x64] [--stages ...]
     .venv/bin/python -m bench.bench_scaling --sizes 128x128 --stages value_iteration,lp_fit
     .venv/bin/python -m bench.bench_scaling --check 32x32   (row generation against the whole LP)
     .venv/bin/python -m bench.bench_scaling --conditioning 64x64 [--whole ipx,ipx-no-crossover]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np

SIZES = ("4x6", "16x16", "32x32", "64x64")
STAGES = ("value_iteration", "rollouts_10k", "lp_fit", "intervals_cells", "intervals_tied")


def _setup(size: str):
    from bench.worlds import cliff_world
    from irl_core.worlds.mdp import build_mdp

    rows, cols = (int(n) for n in size.split("x"))
    return build_mdp(cliff_world(rows, cols))


def run_stage(size: str, stage: str) -> dict:
    """Time one stage after its inputs are built; report seconds, the VI ratio and peak RSS in MiB."""
    from bench.timing import best_of
    from irl_core.players.experts import optimal_policy, rollouts
    from irl_core.worlds.planning import value_iteration

    mdp = _setup(size)
    one_vi = best_of(3, lambda: value_iteration(mdp))
    effort = {}
    if stage.startswith("lp_fit") or stage.startswith("intervals"):
        from bench.fit_stage import demonstrations_for, fit_stage

        demos = demonstrations_for(mdp, episodes=100, seed=0)
        intervals = stage.removeprefix("intervals_") if stage.startswith("intervals") else None
        work: Callable[[], object] = lambda: effort.update(fit_stage(demos, intervals=intervals))  # noqa: E731
    elif stage == "rollouts_10k":
        policy = optimal_policy(mdp)
        work = lambda: rollouts(mdp, policy, episodes=10_000, seed=0)  # noqa: E731
    else:
        work = lambda: value_iteration(mdp)  # noqa: E731
    start = time.perf_counter()
    work()
    seconds = time.perf_counter() - start
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"size": size, "stage": stage, "seconds": seconds, "vi_seconds": one_vi, "peak_mib": peak_mib,
            "states": mdp.n_states, **effort}


def check(size: str) -> None:
    """Row generation against HiGHS's simplex on the whole slack-form LP: the same optimum? And
    the per-cell intervals: every LP answered, each interval holding the true and the fitted reward."""
    from bench.fit_stage import demonstrations_for
    from irl_core.irl.lp.margin import lp_constraints
    from irl_core.irl.lp.solve import solve_margin_lp
    from irl_core.irl.qmap import build_qmap, build_unknowns

    mdp = _setup(size)
    demos = demonstrations_for(mdp, episodes=100, seed=0)
    constraints = lp_constraints(build_qmap(mdp, build_unknowns(mdp)), demos.most_frequent, rmax=1000.0)
    times, margins = {}, {}
    for generate in (True, False):
        start = time.perf_counter()
        solution = solve_margin_lp(constraints, generate_rows=generate)
        times[generate], margins[generate] = time.perf_counter() - start, solution.margin
        print(f"  {'row generation' if generate else 'whole LP':<15} margin {solution.margin:.12g}  "
              f"{times[generate]:.2f} s, {solution.rounds} rounds, {solution.rows} rows, "
              f"violation {constraints.violation(solution.x):.1e}")
    print(f"  relative difference {abs(margins[True] - margins[False]) / abs(margins[False]):.1e}; "
          f"row generation / whole LP time {times[True] / times[False]:.3f}")
    # Every per-cell interval LP answered (on the landed main 4 of 62 at 32x32 ended "unknown"),
    # each interval holding the true reward and the fitted one.
    from irl_core.irl.intervals.identified import reward_intervals

    start = time.perf_counter()
    intervals, _ = reward_intervals(constraints)
    truth = constraints.qmap.unknowns.true_theta(mdp)
    theta = solution.x[: constraints.qmap.k]
    holds = (intervals[:, 0] <= truth + 1e-6) & (truth <= intervals[:, 1] + 1e-6)
    fitted = (intervals[:, 0] <= theta + 1e-6) & (theta <= intervals[:, 1] + 1e-6)
    print(f"  per-cell intervals: {2 * len(intervals)} LPs answered in {time.perf_counter() - start:.1f} s; "
          f"true reward inside {holds.sum()} of {len(intervals)}, fitted reward inside {fitted.sum()}")


WHOLE_ROUTES = {"simplex": {}, "ipx": {"solver": "ipx"}, "ipx-no-crossover": {"solver": "ipx", "run_crossover": "off"}}


def conditioning(size: str, *, whole: list[str]) -> None:
    """Where the margin LP's large row duals sit, and whether the whole LP by other `whole` routes agrees.

    The duals are those of the row-generation model's final optimum; each family row belongs to
    a state, whose distance from the goal (steps, Manhattan on these wall-less worlds) is given.
    """
    from bench.fit_stage import demonstrations_for
    from irl_core.irl.lp.highs import HighsModel
    from irl_core.irl.lp.margin import lp_constraints, margin_lp
    from irl_core.irl.lp.solve import MARGIN_OPTIONS, RowGeneration
    from irl_core.irl.qmap import build_qmap, build_unknowns

    mdp = _setup(size)
    demos = demonstrations_for(mdp, episodes=100, seed=0)
    constraints = lp_constraints(build_qmap(mdp, build_unknowns(mdp)), demos.most_frequent, rmax=1000.0)
    problem = margin_lp(constraints)
    start = time.perf_counter()
    run = RowGeneration(problem, options=MARGIN_OPTIONS)
    z = run.solve()
    seconds = time.perf_counter() - start
    margin = float(-problem.base.cost @ z)
    duals = np.abs(np.array(run.model.highs.getSolution().row_dual)[problem.base.shape[0]:])
    states = run.pairs[:, 0]
    goal = np.array(mdp.cells[mdp.symbols.index("G")])
    distance = np.abs(np.array([mdp.cells[s] for s in states]) - goal).sum(axis=1)
    V = z[problem.qmap.k : problem.qmap.n]
    floor = -float(np.abs(mdp.R_A).min()) / (1 - mdp.gamma)
    print(f"  {size}: margin {margin:.10g}, {run.rounds} rounds, {seconds:.1f} s; "
          f"{np.count_nonzero(duals > 1e-9)} of {duals.size} family rows tight")
    print(f"  largest row dual {duals.max():.3g} at a state {distance[duals.argmax()]} steps from the goal "
          f"(V there {V[states[duals.argmax()]]:.4f}; -min|R_A|/(1 - gamma) = {floor:.1f})")
    for low, high in ((0, 10), (10, 20), (20, 30), (30, 60), (60, 1000)):
        band = (distance >= low) & (distance < high)
        if band.any():
            print(f"    {low:>3}-{high:<4} steps: {band.sum():>6} rows, largest dual {duals[band].max():.3g}, "
                  f"median V {np.median(V[states[band]]):.3f}")
    for name in whole:
        # HiGHS's own answer, without the retries of HighsModel.solve.
        start = time.perf_counter()
        highs = HighsModel(problem.full(), options=WHOLE_ROUTES[name]).highs
        highs.run()
        objective = -highs.getInfo().objective_function_value
        print(f"  whole LP by {name}: {highs.modelStatusToString(highs.getModelStatus())}, objective {objective:.10g}, "
              f"relative difference {abs(objective - margin) / abs(margin):.1e}, "
              f"{time.perf_counter() - start:.0f} s", flush=True)


def measure(sizes=SIZES, stages=STAGES, *, timeout: float = 1800) -> list[dict]:
    rows = []
    for stage in stages:
        for size in sizes:
            try:
                out = subprocess.run(
                    [sys.executable, "-m", "bench.bench_scaling", "--one", size, stage],
                    capture_output=True, text=True, timeout=timeout, check=True,
                )
                rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
            except subprocess.TimeoutExpired:
                rows.append({"size": size, "stage": stage, "seconds": float("nan"), "peak_mib": float("nan"),
                             "error": f"over {timeout:.0f} s"})
            except subprocess.CalledProcessError as exc:
                rows.append({"size": size, "stage": stage, "seconds": float("nan"), "peak_mib": float("nan"),
                             "error": (exc.stderr.strip().splitlines() or ["failed"])[-1]})
            print(_format_row(rows[-1]), flush=True)
    return rows


def growth_exponent(rows: list[dict], stage: str) -> float:
    """k in time ~ states^k, least squares on log-log over the sizes that finished."""
    points = [(r["states"], r["seconds"]) for r in rows if r["stage"] == stage and np.isfinite(r["seconds"]) and "states" in r]
    if len(points) < 2:
        return float("nan")
    cells, seconds = np.array(points).T
    return float(np.polyfit(np.log(cells), np.log(np.maximum(seconds, 1e-6)), 1)[0])


def _effort(row: dict) -> str:
    parts = []
    if row.get("rounds"):
        parts.append(f"fit in {row['rounds']} rounds")
    if row.get("intervals"):
        parts.append(f"{row['intervals']} interval LPs")
    return f", {', '.join(parts)}" if parts else ""


def _format_row(row: dict) -> str:
    if "error" in row:
        return f"  {row['stage']:<16} {row['size']:>7}  ({row['error']})"
    return (f"  {row['stage']:<16} {row['size']:>7} {row['seconds']:>10.3f} s {row['seconds'] / row['vi_seconds']:>8.1f} VI "
            f"{row['peak_mib']:>7.0f} MiB{_effort(row)}")


def table(rows: list[dict]) -> str:
    """A Markdown table: stage, then time, VI ratio and peak memory for each size, and the exponent."""
    sizes = list(dict.fromkeys(r["size"] for r in rows))
    lines = ["| stage | " + " | ".join(sizes) + " | growth k (time ~ states^k) |",
             "|---|" + "---|" * len(sizes) + "---|"]
    for stage in dict.fromkeys(r["stage"] for r in rows):
        cells = []
        for size in sizes:
            r = next(r for r in rows if r["stage"] == stage and r["size"] == size)
            cells.append(r["error"] if "error" in r else
                         f"{r['seconds']:.3g} s = {r['seconds'] / r['vi_seconds']:.3g} VI, {r['peak_mib']:.0f} MiB{_effort(r)}")
        lines.append(f"| {stage} | " + " | ".join(cells) + f" | {growth_exponent(rows, stage):.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default=",".join(SIZES))
    parser.add_argument("--stages", default=",".join(STAGES))
    parser.add_argument("--timeout", type=float, default=1800, help="seconds allowed per stage (default 1800)")
    parser.add_argument("--check", metavar="SIZE", help="compare row generation with the whole LP on one size")
    parser.add_argument("--conditioning", metavar="SIZE", help="where the margin LP's large duals sit")
    parser.add_argument("--whole", default="", help="with --conditioning: also solve the whole LP by these "
                        f"HiGHS routes ({', '.join(WHOLE_ROUTES)}), comma-separated")
    parser.add_argument("--one", nargs=2, metavar=("SIZE", "STAGE"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(run_stage(*args.one)))
        return
    if args.conditioning:
        print(f"conditioning of the margin LP on the {args.conditioning} cliff world:")
        conditioning(args.conditioning, whole=[r for r in args.whole.split(",") if r])
        return
    if args.check:
        print(f"row generation against the whole slack-form LP on the {args.check} cliff world:")
        check(args.check)
        return
    print("scaling on generated cliff worlds with 14 levels (each stage in a fresh process; "
          "VI = one value iteration of the same world, timed in the same process):")
    rows = measure(args.sizes.split(","), args.stages.split(","), timeout=args.timeout)
    print()
    print(table(rows))


if __name__ == "__main__":
    main()
