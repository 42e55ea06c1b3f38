"""A reach world whose limits leave no duration to choose: nothing fixes the points' scale, and the fit says so."""

from __future__ import annotations

from irl_core.reach.fit import RMAX, fit_reaches
from irl_core.reach.players import reacher, simulate_reaches_to_file
from irl_core.recordings.reach_reader import read_reaches
from irl_core.worlds.reach import REACH_WORLDS, ReachWorld


def narrowed(low_ms: float, high_ms: float) -> ReachWorld:
    base = REACH_WORLDS["reach"]
    return ReachWorld.model_validate({**base.model_dump(), "name": "reach-narrow", "min_ms": low_ms, "max_ms": high_ms})


def reaches_of(world: ReachWorld, tmp_path, seed: int = 3):
    path = tmp_path / f"{world.name}-{seed}.jsonl"
    simulate_reaches_to_file(path, world, reacher(world, "boltzmann", beta=0.2), trials=100, seed=seed)
    return read_reaches([path])[0]


def test_one_duration_leaves_the_scale_open_and_every_interval_is_the_whole_range(tmp_path):
    fit = fit_reaches(reaches_of(narrowed(1498.5, 1500.0), tmp_path))
    assert "scale_not_identified" in [note.code for note in fit.notes]
    for symbol, (low, high) in fit.interval.items():
        assert (low, high) == (-RMAX, RMAX)
        assert low <= fit.reward[symbol] <= high


def test_a_known_symbol_fixes_the_scale_there(tmp_path):
    fit = fit_reaches(reaches_of(narrowed(1498.5, 1500.0), tmp_path), known={"G": 100.0})
    assert "scale_not_identified" not in [note.code for note in fit.notes]
    assert fit.interval["G"] == (100.0, 100.0)
    low, high = fit.interval["C"]
    assert -RMAX < low <= -500 <= high < 0


def test_free_durations_keep_their_intervals(tmp_path):
    fit = fit_reaches(reaches_of(REACH_WORLDS["reach"], tmp_path))
    assert "scale_not_identified" not in [note.code for note in fit.notes]
    assert all(-RMAX < low and high < RMAX for low, high in fit.interval.values())


def test_a_fit_of_few_trials_says_its_intervals_are_rough(tmp_path):
    world = REACH_WORLDS["reach"]
    path = tmp_path / "few.jsonl"
    simulate_reaches_to_file(path, world, reacher(world, "boltzmann", beta=0.2), trials=7, seed=1)
    notes = [note for note in fit_reaches(read_reaches([path])[0]).notes if note.code == "few_episodes"]
    assert len(notes) == 1 and "only 7 trials" in notes[0].text
