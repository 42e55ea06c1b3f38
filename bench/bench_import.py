"""`careful import` of a 100,000-row trial table against the recordings' reader reading the same steps.

Writes a lab-style CSV table (participant, trial, move, x and y from the bottom-left, an arrow code, a response
time in seconds) of Boltzmann episodes of `paper`, one participant per 20th episode, until it has `--rows` rows.
Then, in a fresh process: the import (`import_table` and `write_imported`: every row checked, one recording per
participant written and read back), and, after it in the same process, `read_recordings` of the files it wrote.
Reports both times (and the import's CPU time, which a busy machine does not stretch), their ratio, and the
process's peak resident memory during the import (the targets: under 10 s and under 500 MB for 100,000 rows).

Run: .venv/bin/python -m bench bench_import
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from irl_core.players.experts import boltzmann_policy, rollouts
from irl_core.worlds.mdp import DIRECTIONS, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

PARTICIPANTS = 20
ARROWS = {"up": "^", "right": ">", "down": "v", "left": "<"}
MAP = """participant = "subject"
episode = "trial"
t = "move"
state = ["x", "y"]
axes = "xy"
origin = "bottom-left"
action = "key"
rt_s = "rt"
[actions]
up = "^"
right = ">"
down = "v"
left = "<"
"""

IMPORT = """
import json, resource, sys, time
from pathlib import Path
from irl_core.recordings.demonstrations import read_recordings
from irl_core.recordings.importing import import_table, write_imported
from irl_core.recordings.table_map import load_map
from irl_core.worlds.world import load_world
table, out = Path(sys.argv[1]), Path(sys.argv[3])
world, column_map = load_world("paper"), load_map(sys.argv[2])
start, cpu = time.perf_counter(), time.process_time()
paths = write_imported(import_table(table, world, column_map), out)
imported, cpu = time.perf_counter() - start, time.process_time() - cpu
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
recordings, _ = read_recordings(paths)
read = time.perf_counter() - start
print(json.dumps({"import_s": imported, "import_cpu_s": cpu, "read_s": read, "peak_mb": peak / 1024, "files": len(paths),
                  "steps": sum(len(r.steps) for r in recordings)}))
"""


def write_table(path: Path, rows: int, *, seed: int = 0) -> int:
    """A CSV table of at least `rows` moves (whole episodes); returns how many it has."""
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    rng = np.random.default_rng(seed)
    policy = boltzmann_policy(mdp, beta=0.5)
    written = 0
    first_episode = 0
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["subject", "trial", "move", "x", "y", "key", "rt"])
        while written < rows:
            result = rollouts(mdp, policy, episodes=2000, rng=rng)
            rows_rt = rng.lognormal(-0.5, 0.4, size=result.state.size).round(3)
            order = np.lexsort((result.t, result.episode))
            for j in order.tolist():
                episode = first_episode + int(result.episode[j])
                r, c = mdp.cells[int(result.state[j])]
                direction = DIRECTIONS[int(mdp.direction[int(result.action[j])])]
                writer.writerow([f"p{episode % PARTICIPANTS:02d}", episode // PARTICIPANTS, int(result.t[j]) + 1, c,
                                 mdp.world.rows - 1 - r, ARROWS[direction], rows_rt[j]])
            written += result.state.size
            first_episode += result.length.size
    return written


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_import")
    parser.add_argument("--rows", type=int, default=100_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        table, the_map = folder / "trials.csv", folder / "map.toml"
        rows = write_table(table, args.rows)
        the_map.write_text(MAP, encoding="utf-8")
        done = subprocess.run([sys.executable, "-c", IMPORT, str(table), str(the_map), str(folder / "out")],
                              capture_output=True, text=True, check=True)
        m = json.loads(done.stdout)
        size_mb = table.stat().st_size / (1 << 20)
    print(f"importing a {size_mb:.1f} MB table of {rows:,} rows ({m['files']} participants, {m['steps']:,} steps read back):")
    print(f"  careful import      {m['import_s']:7.2f} s   ({m['import_cpu_s']:.2f} s of CPU)   peak memory "
          f"{m['peak_mb']:6.0f} MB (the whole process)")
    print(f"  read_recordings     {m['read_s']:7.2f} s   (the same steps, from the files the import wrote)")
    print(f"  ratio import / read = {m['import_s'] / m['read_s']:.2f}   targets: under 10 s and under 500 MB")


if __name__ == "__main__":
    main()
