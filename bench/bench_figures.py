"""How long `careful experiment` takes with its figures, and what writing them costs.

Target: the whole command (a fresh process: imports, the five stages, 10 figures as PDF and
PNG, the report) under 10 s on this 2-core machine. It reports the command's wall time and
CPU time, and, in this process, the time the figures take against the stages that compute
them (the share of the command that drawing is).

Run: .venv/bin/python bench/bench_figures.py [--repeats N]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.timing import best_of

TARGET_S = 10.0


def command_time(out: Path) -> tuple[float, float]:
    """Wall and CPU seconds of `careful experiment --out OUT` in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "careful_tui.cli", "experiment", "--out", str(out)],
                   check=True, capture_output=True, cwd=out.parent)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3, help="runs of each measurement; the fastest counts")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        runs = [command_time(Path(tmp) / f"run{i}") for i in range(args.repeats)]
        wall, cpu = min(runs)
        verdict = "within" if wall < TARGET_S else "OVER"
        print(f"careful experiment: {wall:.2f} s wall, {cpu:.2f} s CPU (best of {args.repeats}); "
              f"target {TARGET_S:.0f} s: {verdict}")

        import careful_tui.commands.experiment as command
        from irl_core.experiment.run import run_experiment

        recordings = Path(tmp) / "none"
        stages = best_of(args.repeats, lambda: run_experiment(recordings=recordings))
        result = run_experiment(recordings=recordings)
        out = Path(tmp) / "figures"
        out.mkdir()
        command.write_figures(result, out)  # warm: matplotlib imported, fonts cached
        figures = best_of(args.repeats, lambda: command.write_figures(result, out))
        print(f"stages {stages:.2f} s; {len(result.figures)} figures as PDF and PNG {figures:.2f} s "
              f"(ratio figures/stages {figures / stages:.2f}; cores: {os.cpu_count()})")


if __name__ == "__main__":
    main()
