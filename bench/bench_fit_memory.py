"""A fit's peak memory against the recording's size, and against reading the recording alone.

Writes a simulated recording of `--episodes` Boltzmann episodes of `paper` (about 200 MB with the
default), then in a fresh process each: reads it (the baseline), and fits it as `careful fit
--no-view` does, the fit check included. Reports each peak resident memory (the whole process,
interpreter included) and the fit's as a multiple of the reading's. The target: a fit of a 200 MB
recording peaks under 2 GB (issue 31: it was 14 GB, the fit check simulating all its replicates
at once).

Run: nice .venv/bin/python -m bench bench_fit_memory [--episodes N] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from bench.big_recording import write_big_recording

MEASURE = """
import json, resource, sys, time
start = time.perf_counter()
if sys.argv[1] == "read":
    from irl_core.recordings.demonstrations import read_recording
    read_recording(sys.argv[2])
    status = 0
else:
    from careful_tui.cli import main
    status = main(["fit", sys.argv[2], "--no-view", "--json", sys.argv[3]])
seconds = time.perf_counter() - start
print(json.dumps({"status": status, "seconds": seconds, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def measure(how: str, path: Path, out: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", MEASURE, how, str(path), str(out)], capture_output=True, text=True,
                          check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_fit_memory")
    parser.add_argument("--episodes", type=int, default=150_000)
    parser.add_argument("--out", type=Path, help="also write the numbers here as JSON")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path, size_mb = write_big_recording(folder, episodes=args.episodes)
        read = measure("read", path, Path(folder) / "read.json")
        fit = measure("fit", path, Path(folder) / "fit.json")
        check = json.loads((Path(folder) / "fit.json").read_text()).get("fit_check", {})
    numbers = {"file_mb": round(size_mb, 1), "episodes": args.episodes, "read_peak_mb": round(read["peak_mb"]),
               "fit_peak_mb": round(fit["peak_mb"]), "fit_seconds": round(fit["seconds"], 1),
               "fit_over_read": round(fit["peak_mb"] / read["peak_mb"], 2), "fit_status": fit["status"],
               "fit_check_replicates": check.get("replicates"), "fit_check_passed": check.get("passed")}
    print(f"a {size_mb:.0f} MB recording ({args.episodes:,} episodes): reading peaks at {read['peak_mb']:.0f} MB, "
          f"the fit at {fit['peak_mb']:.0f} MB ({numbers['fit_over_read']}x the reading) in {fit['seconds']:.0f} s "
          f"(exit {fit['status']}; fit check {check.get('replicates')} replicates, passed {check.get('passed')})")
    if args.out is not None:
        args.out.write_text(json.dumps(numbers, indent=1) + "\n")


if __name__ == "__main__":
    main()
