"""How cost grows with the world: time and peak memory per stage on generated cliff worlds.

Each (size, stage) runs in a fresh process, so its peak resident memory is its own.
The growth exponent k fits time ~ cells^k over the sizes.
Run: .venv/bin/python -m bench.bench_scaling [--sizes 4x6,16x16,32x32,64x64]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

SIZES = ("4x6", "16x16", "32x32", "64x64")
STAGES = ("value_iteration", "rollouts_10k", "lp_fit", "intervals_tied")


def _setup(size: str):
    from bench.worlds import cliff_world
    from irl_core.mdp import build_mdp

    rows, cols = (int(n) for n in size.split("x"))
    return build_mdp(cliff_world(rows, cols))


def run_stage(size: str, stage: str) -> dict:
    """Time one stage after its inputs are built; report seconds and peak RSS in MiB."""
    from irl_core.experts import optimal_policy, rollouts
    from irl_core.planning import value_iteration

    mdp = _setup(size)
    work = None
    if stage in ("lp_fit", "intervals_tied"):
        from bench.fit_stage import demonstrations_for, fit_stage

        demos = demonstrations_for(mdp, episodes=100, seed=0)
        work = lambda: fit_stage(demos, intervals=stage == "intervals_tied")  # noqa: E731
    elif stage == "rollouts_10k":
        policy = optimal_policy(mdp)
        work = lambda: rollouts(mdp, policy, episodes=10_000, seed=0)  # noqa: E731
    else:
        work = lambda: value_iteration(mdp)  # noqa: E731
    start = time.perf_counter()
    work()
    seconds = time.perf_counter() - start
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"size": size, "stage": stage, "seconds": seconds, "peak_mib": peak_mib, "states": mdp.n_states}


def measure(sizes=SIZES, stages=STAGES, *, timeout: float = 600) -> list[dict]:
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
    """k in time ~ cells^k, least squares on log-log over the sizes that finished."""
    points = [(r["states"], r["seconds"]) for r in rows if r["stage"] == stage and np.isfinite(r["seconds"]) and "states" in r]
    if len(points) < 2:
        return float("nan")
    cells, seconds = np.array(points).T
    return float(np.polyfit(np.log(cells), np.log(np.maximum(seconds, 1e-6)), 1)[0])


def _format_row(row: dict) -> str:
    note = f"  ({row['error']})" if "error" in row else ""
    return f"  {row['stage']:<16} {row['size']:>6} {row['seconds'] * 1e3:>11.1f} ms {row['peak_mib']:>9.0f} MiB{note}"


def table(rows: list[dict]) -> str:
    """A Markdown table: stage, then time and peak memory for each size, and the exponent."""
    sizes = list(dict.fromkeys(r["size"] for r in rows))
    lines = ["| stage | " + " | ".join(sizes) + " | growth k (time ~ states^k, sizes that finished) |",
             "|---|" + "---|" * len(sizes) + "---|"]
    for stage in dict.fromkeys(r["stage"] for r in rows):
        cells = []
        for size in sizes:
            r = next(r for r in rows if r["stage"] == stage and r["size"] == size)
            cells.append(f"{r['error']}" if "error" in r else f"{r['seconds']:.3g} s, {r['peak_mib']:.0f} MiB")
        lines.append(f"| {stage} | " + " | ".join(cells) + f" | {growth_exponent(rows, stage):.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default=",".join(SIZES))
    parser.add_argument("--stages", default=",".join(STAGES))
    parser.add_argument("--one", nargs=2, metavar=("SIZE", "STAGE"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(run_stage(*args.one)))
        return
    print("scaling on generated cliff worlds with 14 levels (each stage in a fresh process):")
    rows = measure(args.sizes.split(","), args.stages.split(","))
    print()
    print(table(rows))


if __name__ == "__main__":
    main()
