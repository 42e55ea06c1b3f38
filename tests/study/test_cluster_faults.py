"""`careful study report --scheduler tcp://...` when the cluster fails: a listener that never speaks, every
worker gone, the scheduler gone. Each is one line and exit 2, in bounded time, never a wait for ever nor
"unexpected error". The scheduler and its worker are real processes here (`dask scheduler`, `dask worker
--no-nanny`), so that killing one is what happens on a real cluster; each is killed on an event (the report's
fits about to be sent, or a call running), never after a fixed wait."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from study.conftest import write_study

from careful_tui.cli import main
from irl_core.errors import ClusterLost
from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study
from irl_core.support import executor as executor_module
from irl_core.support.executor import DaskExecutor, close, scheduler

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.usefixtures("no_dask_thread_left_behind")

# How long a cluster's processes may take to start on a loaded machine (an upper bound on an event, not a wait).
START_S = 120


@pytest.fixture(scope="module")
def study_path(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("study")
    path = write_study(folder, practice=1, episodes=4)
    study = load_study(path)
    for who in simulated_participants(2, betas=(0.5,)):
        write_simulated_participant(study, who)
    return path


class Cluster:
    """A `dask scheduler` process and one `dask worker --no-nanny` (a worker that dies stays dead)."""

    def __init__(self, folder: Path) -> None:
        self.file = folder / "scheduler.json"
        # The calls below are this module's functions: the scheduler and the worker import them as the tests do.
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=folder)
        self.scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host",
                                           "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
                                           str(self.file)], **quiet)
        self.worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file",
                                        str(self.file), "--no-nanny", "--nthreads", "1", "--no-dashboard"], **quiet)
        self.address = ""

    def started(self) -> str:
        """The scheduler's address, once its one worker has joined."""
        client = distributed.Client(scheduler_file=str(self.file), timeout=START_S)
        try:
            client.wait_for_workers(1, timeout=START_S)
        finally:
            client.close()
        self.address = json.loads(self.file.read_text())["address"]
        return self.address

    def stop(self) -> None:
        for process in (self.worker, self.scheduler):
            if process.poll() is None:
                process.kill()
            process.wait()


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    started = Cluster(tmp_path)
    try:
        started.started()
        yield started
    finally:
        started.stop()


@pytest.fixture
def silent_listener() -> Iterator[str]:
    """A tcp address that accepts connections and never says a word."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    accepted: list[socket.socket] = []

    def accept() -> None:
        while True:
            try:
                accepted.append(server.accept()[0])
            except OSError:
                return

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.shutdown(socket.SHUT_RDWR)  # wakes the thread's accept (a close alone does not)
    server.close()
    thread.join()
    for connection in accepted:
        connection.close()


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "unexpected error" not in err and "Please report" not in err and "Traceback" not in err
    return lines[0]


def test_a_listener_that_accepts_and_never_speaks_is_one_line_and_exit_2_within_10_s(study_path, silent_listener,
                                                                                      capsys):
    start = time.perf_counter()
    assert main(["study", "report", str(study_path), "--scheduler", silent_listener]) == 2
    seconds = time.perf_counter() - start
    line = one_line(capsys.readouterr().err)
    assert silent_listener in line and "not a Dask scheduler" in line
    assert seconds < 10, seconds  # the documented promise


def _on_first_run(monkeypatch, then) -> None:
    """`then()` once, as the report hands its first fits to the cluster (mid-report: the participants are read)."""
    real_run = DaskExecutor.run
    done = []

    def run(self, *args, **kwargs):
        if not done:
            done.append(then())
        return real_run(self, *args, **kwargs)

    monkeypatch.setattr(DaskExecutor, "run", run)


def _killed(process: subprocess.Popen) -> None:
    process.send_signal(signal.SIGKILL)
    process.wait()


def test_every_worker_killed_mid_report_is_one_line_naming_what_is_missing_and_exit_2(study_path, cluster, capsys,
                                                                                       monkeypatch):
    monkeypatch.setattr(executor_module, "NO_WORKERS_S", 2.0)
    _on_first_run(monkeypatch, lambda: _killed(cluster.worker))
    assert main(["study", "report", str(study_path), "--scheduler", cluster.address, "--resamples", "20"]) == 2
    line = one_line(capsys.readouterr().err)
    assert cluster.address in line and "no worker" in line and "not fitted: " in line and "pooled" in line
    assert not (study_path.parent / "data" / "report").exists()  # nothing half-written


# The report in a process of its own, so that its stderr is the user's (Dask's log handler included); the
# scheduler is killed as the report hands its first fits to the cluster.
KILL_THEN_REPORT = """
import os, signal, sys
from careful_tui.cli import main
from irl_core.support.executor import DaskExecutor
real_run = DaskExecutor.run
def run(self, *args, **kwargs):
    if not getattr(run, "done", False):
        run.done = True
        os.kill(int(sys.argv[3]), signal.SIGKILL)
    return real_run(self, *args, **kwargs)
DaskExecutor.run = run
sys.exit(main(["study", "report", sys.argv[1], "--scheduler", sys.argv[2], "--resamples", "20"]))
"""


def test_the_scheduler_killed_mid_report_is_one_line_and_exit_2(study_path, cluster):
    start = time.perf_counter()
    report = subprocess.run([sys.executable, "-c", KILL_THEN_REPORT, str(study_path), cluster.address,
                             str(cluster.scheduler.pid)], capture_output=True, text=True, timeout=START_S)
    seconds = time.perf_counter() - start
    assert report.returncode == 2, report.stderr
    line = one_line(report.stderr)  # Dask's own "Failed to reconnect to scheduler" line is not there
    assert cluster.address in line and "scheduler" in line and "not fitted: " in line
    assert seconds < 60, seconds


def _kill_own_worker(started: str, value: int) -> int:
    """A call that says it started (a file), then ends its worker's process: no nanny brings it back."""
    Path(started).touch()
    os._exit(1)


def _kill_scheduler(started: str, pid: int, value: int) -> int:
    """A call that kills the scheduler while it runs, and then waits for a result that will never be asked for."""
    Path(started).touch()
    os.kill(pid, signal.SIGKILL)
    threading.Event().wait(600)
    return value


def test_a_run_whose_only_worker_dies_mid_call_raises_cluster_lost_naming_the_calls(cluster, tmp_path, monkeypatch):
    monkeypatch.setattr(executor_module, "NO_WORKERS_S", 2.0)
    executor = scheduler(cluster.address)
    got: dict[int, int] = {}
    try:
        with pytest.raises(ClusterLost, match="no worker") as raised:
            executor.run(_kill_own_worker, [(1,), (2,)], shared=(str(tmp_path / "started"),),
                         on_result=got.__setitem__)
    finally:
        close(executor)
    assert (tmp_path / "started").exists() and got == {}
    assert raised.value.missing == (0, 1)


def test_a_run_whose_scheduler_dies_mid_call_raises_cluster_lost(cluster, tmp_path):
    executor = scheduler(cluster.address)
    try:
        with pytest.raises(ClusterLost, match="scheduler") as raised:
            executor.run(_kill_scheduler, [(1,)], shared=(str(tmp_path / "started"), cluster.scheduler.pid),
                         on_result=lambda i, value: None)
    finally:
        close(executor)
    assert (tmp_path / "started").exists() and raised.value.missing == (0,)
