"""The fit check simulates its replicates a chunk at a time, so its memory does not grow with them.

All 200 replicates at once had made a fit's memory about 100x the recording (14 GB for 214 MB,
issue 31); `bench/bench_fit_memory.py` measures a 200 MB recording's peak.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import irl_core.irl.fit_check as fit_check_module
from irl_core.irl.fit_check import fit_check
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


@pytest.fixture(scope="module")
def played():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    policy = boltzmann_policy(mdp, beta=0.1)
    return mdp, policy, demonstrations_of(mdp, rollouts(mdp, policy, episodes=1500, seed=0))


def peak_bytes(mdp, policy, demos, replicates: int) -> int:
    tracemalloc.start()
    try:
        check = fit_check(mdp, policy, demos.by_episode, demos.episode_facts, replicates=replicates, seed=0)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        assert check.replicates == replicates


def test_the_checks_peak_memory_does_not_grow_with_its_replicates(played, monkeypatch) -> None:
    mdp, policy, demos = played
    steps = int(demos.episode_facts.length.sum())
    monkeypatch.setattr(fit_check_module, "CHUNK_STEPS", 2 * steps)  # two replicates a chunk
    few, many = peak_bytes(mdp, policy, demos, 4), peak_bytes(mdp, policy, demos, 40)
    assert many < 1.5 * few, f"40 replicates peaked at {many / few:.1f}x what 4 did"


def test_chunked_replicates_give_a_verdict_on_every_statistic(played, monkeypatch) -> None:
    """Chunks of one replicate (a fresh simulation each) still give the check every band, and a
    Boltzmann player checked against its own policy passes."""
    mdp, policy, demos = played
    whole = fit_check(mdp, policy, demos.by_episode, demos.episode_facts, replicates=60, seed=1)
    monkeypatch.setattr(fit_check_module, "CHUNK_STEPS", 1)
    chunked = fit_check(mdp, policy, demos.by_episode, demos.episode_facts, replicates=60, seed=1)
    assert [s.name for s in chunked.statistics] == [s.name for s in whole.statistics]
    assert chunked.passed and whole.passed
    for a, b in zip(whole.statistics, chunked.statistics):
        assert np.isclose(a.observed, b.observed)
        assert a.low <= a.observed <= a.high and b.low <= b.observed <= b.high
