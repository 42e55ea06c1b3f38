"""`careful study report --scheduler`: the report's fits on a Dask cluster give the local pool's numbers to
the last digit; an address that does not answer is one line and exit 2; a worker that dies has its fits rerun
elsewhere, or named as missing, never silently dropped."""

import os
import time

import numpy as np
import pytest
from study.conftest import write_study

from careful_tui.cli import main
from irl_core.errors import LostCall, SchedulerError
from irl_core.irl.intervals.bootstrap import bootstrap
from irl_core.studies.report import POOLED, fit_report, gather, report_options, run_fits
from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study
from irl_core.support.executor import LocalPool, close, scheduler

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.usefixtures("no_dask_thread_left_behind")
# How long a restarted worker may take to join on a loaded machine (a bound on an event, not a wait).
START_S = 120


@pytest.fixture(scope="module")
def study_path(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    path = write_study(folder, practice=1, episodes=4)
    study = load_study(path)
    for who in simulated_participants(3, betas=(0.3, 1.5)):
        write_simulated_participant(study, who)
    return path


@pytest.fixture(scope="module")
def cluster():
    executor = scheduler("local:2")
    yield executor
    close(executor)


def same_fits(first, second):
    assert len(first) == len(second)
    for a, b in zip(first, second):
        assert (a.error, a.symbols, a.method, a.player_model, a.beta) == (b.error, b.symbols, b.method, b.player_model,
                                                                           b.beta)
        for x, y in ((a.estimate, b.estimate), (a.intervals, b.intervals)):
            assert (x is None) == (y is None)
            if x is not None:
                np.testing.assert_array_equal(x, y)  # to the last digit
        assert [i and i.without for i in a.influence or ()] == [i and i.without for i in b.influence or ()]


def test_the_report_on_a_local_cluster_is_the_local_pools_to_the_last_digit(study_path, cluster):
    data = gather(load_study(study_path))
    options = report_options(resamples=20, seed=3)
    local = fit_report(data, options, workers=2)
    remote = fit_report(data, options, executor=cluster)
    same_fits(local, remote)
    assert any(fit.intervals is not None for fit in remote) and all(fit.error is None for fit in remote)


def test_one_pools_bootstrap_runs_on_the_cluster_in_batches_with_the_same_intervals(study_path, cluster, monkeypatch):
    data = gather(load_study(study_path))
    pool = data.cell(POOLED, 0)
    options = report_options(resamples=30, seed=1)
    sent = []
    real_run = type(cluster).run

    def counting(self, function, calls, **kwargs):
        sent.append(len(calls))
        return real_run(self, function, calls, **kwargs)

    monkeypatch.setattr(type(cluster), "run", counting)
    [remote] = run_fits([pool], options, executor=cluster)
    [local] = run_fits([pool], options, workers=2)
    same_fits([local], [remote])
    # The refits went to the cluster, in fewer tasks than resamples (batches), and all came back.
    assert sent and sent[0] < options.resamples


def test_a_scheduler_that_does_not_answer_exits_2_within_10_s_naming_the_address(study_path, capsys):
    start = time.perf_counter()
    assert main(["study", "report", str(study_path), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert time.perf_counter() - start < 10
    err = capsys.readouterr().err
    assert "tcp://127.0.0.1:9" in err and "no Dask scheduler answered" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("address", ["local:0", "banana", "local:x"])
def test_a_scheduler_of_no_known_form_is_refused_naming_it(address):
    with pytest.raises(SchedulerError, match=address):
        scheduler(address)


def _die_first_time(marker: str, value: int) -> int:
    """The call's worker dies the first time (the marker file does not exist yet); a rerun returns value."""
    if not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return value * 10


def _die_together_first_time(folder: str, value: int) -> int:
    """Both calls start, wait for each other, and their workers die together (with every copy of the run's
    shared data); a rerun returns value."""
    marker = os.path.join(folder, f"died-{value}")
    if os.path.exists(marker):
        return value * 10
    open(os.path.join(folder, f"started-{value}"), "w").close()
    deadline = time.monotonic() + 120  # a bound on the other call's start, not a wait
    while len([name for name in os.listdir(folder) if name.startswith("started-")]) < 2:
        assert time.monotonic() < deadline, "the other call did not start"
        time.sleep(0.01)
    open(marker, "w").close()
    os._exit(1)


def _always_die(value: int) -> int:
    if value == 2:
        os._exit(1)
    return value * 10


def test_a_call_whose_worker_dies_reruns_elsewhere(cluster, tmp_path):
    got = {}
    cluster.run(_die_first_time, [(1,), (2,)], shared=(str(tmp_path / "died"),), on_result=got.__setitem__)
    assert got == {0: 10, 1: 20}


def test_calls_whose_workers_all_die_at_once_with_the_shared_data_are_sent_again(cluster, tmp_path):
    # Scattered data cannot be recomputed: the scheduler cancels the calls that needed it (CI saw this
    # as "already forgotten" when both of the test above's calls died at once). They are sent again.
    # Both calls must run at once: the worker the test above killed is back first (on a loaded machine its
    # nanny takes a while), else both go to the one worker left, where the first waits for the second.
    cluster.client.wait_for_workers(2, timeout=START_S)
    got = {}
    cluster.run(_die_together_first_time, [(1,), (2,)], shared=(str(tmp_path),), on_result=got.__setitem__)
    assert got == {0: 10, 1: 20}
    assert sorted(os.listdir(tmp_path)) == ["died-1", "died-2", "started-1", "started-2"]


def test_a_call_that_kills_every_worker_it_meets_is_named_missing_not_dropped():
    executor = scheduler("local:1")
    try:
        with _allowed_failures(executor.cluster, 0):
            got, lost = {}, {}
            executor.run(_always_die, [(1,), (2,)], on_result=got.__setitem__, on_lost=lost.__setitem__)
            # The other call may have been on the dying worker too: then it is named as well, never dropped.
            assert 1 in lost and "worker died" in lost[1] and set(got) | set(lost) == {0, 1}
            assert got.get(0, 10) == 10
            with pytest.raises(LostCall):
                executor.run(_always_die, [(2,)], on_result=got.__setitem__)
    finally:
        close(executor)


class _allowed_failures:
    """The scheduler gives a call up after this many workers died running it."""

    def __init__(self, cluster, n):
        self.scheduler, self.n = cluster.scheduler, n

    def __enter__(self):
        self.before, self.scheduler.allowed_failures = self.scheduler.allowed_failures, self.n

    def __exit__(self, *exc):
        self.scheduler.allowed_failures = self.before


def test_the_bootstrap_through_the_local_pool_executor_is_the_bootstraps_own():
    # The seam changes nothing for the default: LocalPool(2) and workers=2 give the same refits.
    from irl_core.irl.intervals.bootstrap import Refit
    from irl_core.irl.qmap import build_unknowns
    from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
    from irl_core.worlds.mdp import build_mdp
    from irl_core.worlds.world import BUILTIN_WORLDS

    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=1.0), episodes=12, seed=0))
    unknowns = build_unknowns(mdp)
    refit = Refit(mdp, unknowns, "maxent", rmax=2000.0, lam=0.0, beta=1.0, start=(np.zeros(unknowns.k), 1.0))
    full = refit(demos.counts)
    kwargs = dict(confidence=0.9, resamples=12, seed=0)
    a = bootstrap(refit, demos.by_episode, full, workers=2, **kwargs)
    b = bootstrap(refit, demos.by_episode, full, executor=LocalPool(2), **kwargs)
    np.testing.assert_array_equal(a.estimates, b.estimates)
