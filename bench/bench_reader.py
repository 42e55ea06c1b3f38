"""The recording reader's memory and time against the file's size and a bare `json.loads` of each line.

Writes a simulated recording of `--episodes` Boltzmann episodes of `paper`, then reads it in a
fresh process each way and reports peak resident memory above the interpreter's own, as a
multiple of the file's size, and the time against a loop that only parses each line's JSON
(the least any reader must do).

Run: .venv/bin/python -m bench bench_reader
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from bench.big_recording import write_big_recording

READ = """
import json, resource, sys, time
from pathlib import Path
path = Path(sys.argv[2])
import irl_core.recordings.demonstrations as d, numpy
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
if sys.argv[1] == "careful":
    steps = len(d.read_recording(path).steps)
else:
    steps = 0
    with open(path, "rb") as file:
        for line in file:
            steps += json.loads(line)["kind"] == "step"
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"steps": steps, "seconds": seconds, "extra_kb": peak - base}))
"""


def measure(how: str, path: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", READ, how, str(path)], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_reader")
    parser.add_argument("--episodes", type=int, default=100_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path, size_mb = write_big_recording(folder, episodes=args.episodes)
        careful, bare = measure("careful", path), measure("json", path)
    print(f"reading a {size_mb:.0f} MB recording ({careful['steps']:,} steps):")
    for name, m in (("read_recording", careful), ("json.loads per line", bare)):
        print(f"  {name:20s} {m['seconds']:7.1f} s   peak memory +{m['extra_kb'] / 1024:7.0f} MB "
              f"= {m['extra_kb'] / 1024 / size_mb:.2f}x the file")
    print(f"  ratio read_recording / json.loads time = {careful['seconds'] / bare['seconds']:.2f}")


if __name__ == "__main__":
    main()
