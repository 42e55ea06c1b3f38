"""The study report's fits on a Dask LocalCluster against this machine's process pool, same study, same seeds.

N simulated participants (default 200) x 1 world (`paper`) x 10 main episodes, 200 resamples per fit: the
pool's fit (its bootstrap's refits batched into tasks), then every participant's fit and the pool without each
of them. Timed first on the local pool of 2 processes, then with ``--scheduler local:2`` (the cluster's start
timed apart: a cluster that is already running does not pay it). Target: the cluster's fits within 1.2x of the
pool's, and every number the same to the last digit (estimates and intervals compared with ==).

Run: .venv/bin/python -m bench bench_study_cluster [--participants N] [--resamples N] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from irl_core.studies.report import fit_report, gather, report_options
from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study
from irl_core.support.executor import close, scheduler

STUDY = """\
name = "cluster"
worlds = ["paper"]
order = "shuffled"
practice_episodes = 1
episodes = 10
input = "hold"
out = "data"
"""
TARGET_RATIO = 1.2


def identical(first: list, second: list) -> tuple[bool, int]:
    """Whether two reports' fits agree to the last digit, and how many numbers were compared."""
    compared = 0
    for a, b in zip(first, second, strict=True):
        if a.error != b.error:
            return False, compared
        for x, y in ((a.estimate, b.estimate), (a.intervals, b.intervals)):
            if (x is None) != (y is None) or (x is not None and not np.array_equal(x, y, equal_nan=True)):
                return False, compared
            compared += 0 if x is None else x.size
    return True, compared


def run(participants: int, resamples: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cluster.toml"
        path.write_text(STUDY)
        study = load_study(path)
        for who in simulated_participants(participants, betas=(0.2, 2.0)):
            write_simulated_participant(study, who)
        data = gather(study)
        options = report_options(resamples=resamples)
        load = os.getloadavg()[0]
        start = time.perf_counter()
        local = fit_report(data, options, workers=2)
        local_s = time.perf_counter() - start
        start = time.perf_counter()
        executor = scheduler("local:2")
        startup_s = time.perf_counter() - start
        try:
            start = time.perf_counter()
            remote = fit_report(data, options, executor=executor)
            remote_s = time.perf_counter() - start
        finally:
            close(executor)
        same, numbers = identical(local, remote)
        return {"participants": participants, "resamples": resamples, "fits": len(local), "local_s": local_s,
                "cluster_s": remote_s, "cluster_start_s": startup_s, "ratio": remote_s / local_s, "identical": same,
                "numbers": numbers, "load_before": load, "load_after": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_study_cluster", description=__doc__.split("\n\n")[0])
    parser.add_argument("--participants", type=int, default=200)
    parser.add_argument("--resamples", type=int, default=200)
    parser.add_argument("--out", default=None, help="also write the row as a JSON line here")
    args = parser.parse_args()
    row = run(args.participants, args.resamples)
    print(f"{row['participants']} participants x 10 episodes, {row['resamples']} resamples, {row['fits']} rows "
          "(and each pool without each participant) "
          f"(load {row['load_before']:.1f} before, {row['load_after']:.1f} after): local pool of 2 "
          f"{row['local_s']:.1f} s, local:2 cluster {row['cluster_s']:.1f} s (+ {row['cluster_start_s']:.1f} s to "
          f"start it) = {row['ratio']:.2f}x ({'meets' if row['ratio'] <= TARGET_RATIO else 'misses'} "
          f"{TARGET_RATIO}x); {row['numbers']} numbers {'identical' if row['identical'] else 'DIFFERENT'}")
    if args.out:
        with open(args.out, "a", encoding="utf-8") as out:
            out.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
