"""The pool's workers die with the process that started them, whatever signal ends it.

Before, SIGTERM or SIGKILL of `careful study report` (or of `fit --intervals` mid-bootstrap) left
every worker alive, blocked on its queue forever at about 70 MB each.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hardening_checks import recording

from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study

# The parent: a pool of 2 workers, each call sleeping far longer than the test waits.
POOL_SCRIPT = """
import sys, time
from irl_core.support.pool import run_in_pool
run_in_pool(time.sleep, [(600,)] * 4, workers=2, on_result=lambda i, r: None)
"""


def children(pid: int) -> set[int]:
    """The pids whose parent is `pid` (from /proc)."""
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.add(int(entry.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def wait_for(condition, timeout: float = 30.0) -> bool:
    """Poll `condition` until true or `timeout` (a generous bound, not a timing assertion)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.05)
    return condition()


def kill_and_check(process: subprocess.Popen, workers: int, sig: int) -> None:
    assert wait_for(lambda: len(children(process.pid)) >= workers), "the pool never started its workers"
    started = children(process.pid)
    process.send_signal(sig)
    process.wait(timeout=30)
    try:
        assert wait_for(lambda: not any(alive(pid) for pid in started), timeout=20), \
            f"workers {sorted(p for p in started if alive(p))} outlived their parent"
    finally:
        for pid in started:
            if alive(pid):
                os.kill(pid, signal.SIGKILL)


pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_pool_workers_die_with_their_parent(sig):
    process = subprocess.Popen([sys.executable, "-c", POOL_SCRIPT], env=os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)})
    kill_and_check(process, 2, sig)


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_fit_intervals_killed_mid_bootstrap_leaves_no_worker(tmp_path, sig):
    rec = recording(tmp_path / "a.jsonl", world="mud", episodes=40)
    process = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", "fit", str(rec), "--no-view", "--method",
                                "maxent", "--intervals", "--resamples", "5000"],
                               env=os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)},
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    kill_and_check(process, 2, sig)


def test_study_report_killed_mid_fits_leaves_no_worker(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text('worlds = ["mud"]\nepisodes = 30\npractice_episodes = 0\n')
    loaded = load_study(study)
    for who in simulated_participants(3):
        write_simulated_participant(loaded, who)
    process = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", "study", "report", str(study),
                                "--workers", "2", "--resamples", "20000"],
                               env=os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)},
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    kill_and_check(process, 2, signal.SIGKILL)


# Calls that cannot be pickled (a lambda among their arguments) between ones that can.
UNPICKLABLE_SCRIPT = """
import time
from irl_core.support.pool import run_in_pool
got = []
try:
    run_in_pool(time.sleep, [(0.01,), (lambda: 1,)] * 4, workers=2, on_result=lambda i, r: got.append(i))
except Exception as error:
    print("raised", type(error).__name__)
"""


def test_a_call_that_cannot_be_pickled_raises_and_the_process_ends():
    # The pool once pickled the calls in its own thread, and the error left its shutdown waiting for ever.
    done = subprocess.run([sys.executable, "-c", UNPICKLABLE_SCRIPT], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() in ("raised PicklingError", "raised AttributeError")  # as pickle words it


def test_results_come_back_for_every_call_of_a_long_list():
    # Calls go to the pool a few at a time: every one still runs once and is handed back with its index.
    from irl_core.support.pool import run_in_pool

    got: dict[int, int] = {}
    run_in_pool(pow, [(i, 2) for i in range(40)], workers=2, on_result=got.__setitem__)
    assert got == {i: i * i for i in range(40)}
