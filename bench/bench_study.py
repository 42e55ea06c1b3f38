"""A study's report: 20 simulated participants x 2 worlds x 10 main episodes, with intervals.

What `careful study report` does, part by part, on the cores of this machine: reading every
participant folder, the 42 fits (20 participants and the pool, per world; maxent with beta
estimated and 200 bootstrap resamples each; a pool's resamples participants, then episodes) and
the 40 point fits of each pool without each participant (their influence), in one process pool,
and the figures (PNG and PDF).
Target: the whole under 2 minutes on 2 cores, and under 60 s of CPU, so that it holds when
the two cores are shared with other work (half of 2 cores for 2 minutes is 120 CPU seconds). The
baseline in the same process is one fit of one participant with its 200 resamples, so the fits'
ratio says how well the pool spreads them.

Run: .venv/bin/python -m bench bench_study
"""

from __future__ import annotations

import os
import resource
import tempfile
import time
from pathlib import Path

from careful_tui.commands.study_report import write_report
from irl_core.studies.report import fit_cell, fit_report, gather, influence_cells, report_options
from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study

STUDY = """\
name = "bench"
worlds = ["paper", "mud"]
order = "shuffled"
practice_episodes = 1
episodes = 10
input = "hold"
out = "data"
"""
PARTICIPANTS = 20
TARGET_S = 120.0
TARGET_CPU_S = 60.0


def cpu_seconds() -> float:
    """CPU time of this process and of its finished children (the pool's workers), user and system."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def main() -> None:
    cores = os.cpu_count()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.toml"
        path.write_text(STUDY)
        study = load_study(path)
        start = time.perf_counter()
        for who in simulated_participants(PARTICIPANTS, betas=(0.2, 2.0)):
            write_simulated_participant(study, who)
        simulate = time.perf_counter() - start
        options = report_options(resamples=200)

        cpu = {}
        load_before = os.getloadavg()[0]
        start, start_cpu = time.perf_counter(), cpu_seconds()
        data = gather(study)
        reading, cpu["reading"] = time.perf_counter() - start, cpu_seconds() - start_cpu
        start, start_cpu = time.perf_counter(), cpu_seconds()
        fits = fit_report(data, options)
        fitting, cpu["fits"] = time.perf_counter() - start, cpu_seconds() - start_cpu
        start, start_cpu = time.perf_counter(), cpu_seconds()
        written = write_report(data, fits, study.report_folder)
        figures, cpu["figures"] = time.perf_counter() - start, cpu_seconds() - start_cpu

        one = data.cells[0]
        start = time.perf_counter()
        fit_cell(one, options)
        baseline = time.perf_counter() - start
        without = influence_cells(data)
        start = time.process_time()
        for cell in without:
            fit_cell(cell, options)
        influence = time.process_time() - start
        total = reading + fitting + figures
        print(f"{PARTICIPANTS} participants x 2 worlds x 10 main episodes; {len(fits)} fits with 200 resamples "
              f"and {len(without)} without one participant "
              f"({cores} cores, load {load_before:.1f} before, {os.getloadavg()[0]:.1f} after)")
        print(f"  simulating the participants {simulate:7.1f} s  (not part of the report)")
        print(f"  reading                     {reading:7.1f} s wall  {cpu['reading']:7.1f} s CPU")
        print(f"  fits                        {fitting:7.1f} s wall  {cpu['fits']:7.1f} s CPU  "
              f"{fitting / baseline:5.1f}x one participant's fit ({baseline:.2f} s)")
        print(f"    of which the {len(without)} pools without one participant, one by one here: {influence:5.1f} s CPU  "
              f"{influence / baseline:5.1f}x one participant's fit")
        print(f"  figures ({len(written) - 1} files)         {figures:7.1f} s wall  {cpu['figures']:7.1f} s CPU")
        used = sum(cpu.values())
        print(f"  report                      {total:7.1f} s wall  {used:7.1f} s CPU  (targets < {TARGET_S:.0f} s wall: "
              f"{'met' if total < TARGET_S else 'NOT met'} at this load; < {TARGET_CPU_S:.0f} s CPU: "
              f"{'met' if used < TARGET_CPU_S else 'NOT met'})")


if __name__ == "__main__":
    main()
