"""A maxent fit asked to stop ends within one objective evaluation, not at the end of L-BFGS-B.

Evaluations are counted (each soft Bellman fixed point and gradient, `maxent._likelihood`),
never seconds: the machine is shared.
"""

import multiprocessing
import os
import time

import numpy as np
import pytest
from maxent_evaluations import count_evaluations

from bench.fit_stage import demonstrations_for
from bench.worlds import cliff_world
from irl_core.irl import Stopped, fit, maxent
from irl_core.irl.intervals.bootstrap import Refit, bootstrap
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.support import pool as pool_module
from irl_core.support.stopping import stop_when
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


@pytest.fixture(scope="module")
def noisy_mud():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    return demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=0.5), episodes=30, seed=0))


@pytest.fixture
def evaluations(monkeypatch):
    return count_evaluations(monkeypatch)


@pytest.mark.parametrize("beta", [1.0, "auto"])
def test_a_maxent_fit_told_to_stop_starts_no_further_evaluation(noisy_mud, evaluations, beta):
    fit(noisy_mud, method="maxent", beta=beta)
    whole = evaluations[0]
    assert whole > 20  # the fit is long enough for stopping at the 5th to matter
    evaluations[0] = 0
    with pytest.raises(Stopped):
        fit(noisy_mud, method="maxent", beta=beta, stop=lambda: evaluations[0] >= 5)
    assert evaluations[0] == 5


@pytest.mark.parametrize("beta", [1.0, "auto"])
def test_a_stop_that_never_says_yes_changes_nothing(noisy_mud, evaluations, beta):
    plain = fit(noisy_mud, method="maxent", beta=beta)
    asked = [0]

    def never():
        asked[0] += 1
        return False

    evaluations[0] = 0
    watched = fit(noisy_mud, method="maxent", beta=beta, stop=never)
    assert asked[0] >= evaluations[0] > 20  # asked at every evaluation at least ...
    np.testing.assert_array_equal(watched.theta, plain.theta)  # ... and to the last bit the same answer
    np.testing.assert_array_equal(watched.V, plain.V)
    assert watched.beta == plain.beta and watched.notes == plain.notes


def test_the_bootstraps_refits_in_this_process_stop_too(noisy_mud, evaluations):
    """A resample's refit ends with Stopped, not a "failed" resample, and the next is not started."""
    mdp = noisy_mud.mdp
    unknowns = build_unknowns(mdp, reward_cells="special", tie=False)
    refit = Refit(mdp=mdp, unknowns=unknowns, method="maxent", rmax=1000.0, lam=0.0, beta=1.0,
                  start=(np.zeros(unknowns.k), 1.0))
    with stop_when(lambda: evaluations[0] >= 3), pytest.raises(Stopped):
        bootstrap(refit, noisy_mud.by_episode, np.zeros(unknowns.k), confidence=0.9, resamples=20, seed=0, workers=1)
    assert evaluations[0] == 3


def test_a_fit_with_maxent_intervals_stops_inside_a_resamples_refit(noisy_mud, evaluations):
    options = dict(method="maxent", beta=1.0, intervals=True, resamples=20, workers=1)
    heard = []
    fit(noisy_mud, **options, progress=lambda stage, done, total: heard.append(evaluations[0]))
    first, second = heard[:2]  # evaluations until the first and the second resample's refits came back
    assert second - first > 2
    evaluations[0] = 0
    with pytest.raises(Stopped):
        fit(noisy_mud, **options, stop=lambda: evaluations[0] >= first + 2)
    assert evaluations[0] == first + 2  # inside the second refit, not at its progress report


def test_the_bootstraps_workers_stop_their_refits_too(monkeypatch):
    """Told to stop while the pool's workers refit, the fit used to notice at the next chunk's
    report and then wait for every chunk still queued (65 s of a 16x16 world's 200 resamples):
    it now asks every STOP_POLL_S and the workers stop their refits at their next check.
    The workers' evaluations are counted and timed (forked workers inherit the counter, and the
    monotonic clock is the machine's)."""
    fork = multiprocessing.get_context("fork")
    monkeypatch.setattr(pool_module, "process_context", lambda: fork)
    in_workers = fork.Value("i", 0)
    last_in_workers = fork.Value("d", 0.0)
    parent = os.getpid()
    real = maxent._likelihood

    def counted(*args, **kwargs):
        answer = real(*args, **kwargs)
        if os.getpid() != parent:
            with in_workers.get_lock():
                in_workers.value += 1
                last_in_workers.value = time.monotonic()
        return answer

    told: list[float] = []

    def stop() -> bool:
        if in_workers.value >= 5:
            told.append(time.monotonic())
        return bool(told)

    monkeypatch.setattr(maxent, "_likelihood", counted)
    demos = demonstrations_for(build_mdp(cliff_world(16, 16)), episodes=20, seed=0)
    reports = []
    with pytest.raises(Stopped):
        fit(demos, method="maxent", beta=1.0, intervals=True, resamples=200, workers=2,
            stop=stop, progress=lambda stage, done, total: reports.append(done))
    # Told 5 evaluations into the first chunks (13 resamples each, over a hundred evaluations): no chunk
    # came back, and the workers' last evaluation ended within a poll and a second of being told (in
    # evaluations that depends on their speed: 51 once the big worlds' solves went to band matrices).
    assert reports == []
    assert last_in_workers.value - told[0] < pool_module.STOP_POLL_S + 1.0, (in_workers.value, told[0])
