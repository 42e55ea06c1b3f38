"""Time worlds (docs/timing.md): care is how long the key is held, and every method sees its bins as levels."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from irl_core.errors import RecordingError, WorldError
from irl_core.play.game import Game
from irl_core.players.experts import optimal_policy, simulate_to_file
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World, world_from_dict

MUD_TIME = BUILTIN_WORLDS["mud-time"]


def test_the_built_in_time_worlds_have_the_documented_curve_and_sixteen_log_spaced_bins():
    for name, twin in (("paper-time", "paper"), ("mud-time", "mud")):
        world = BUILTIN_WORLDS[name]
        assert world.layout == BUILTIN_WORLDS[twin].layout and world.rewards == BUILTIN_WORLDS[twin].rewards
        assert (world.care, world.p0, world.p_inf, world.tau_ms, world.cost_per_second, world.max_hold_ms) == (
            "time", 0.5, 0.0, 400.0, 5.0, 4000.0)
    edges = np.array(MUD_TIME.duration_bins_ms)
    assert edges[0] == 0 and edges[-1] == 4000 and MUD_TIME.levels == len(edges) - 1 == 16
    ratios = edges[2:] / edges[1:-1]
    assert ratios == pytest.approx(np.full(ratios.size, (4000 / 20) ** (1 / 16)), rel=0.03)  # log-spaced


def test_a_bins_action_slips_and_costs_as_its_geometric_mid_point():
    world = world_from_dict({"layout": "..G\n", "care": "time", "duration_bins_ms": [0, 100, 400, 4000]})
    mids = [np.sqrt(20 * 100), np.sqrt(100 * 400), np.sqrt(400 * 4000)]
    assert world.bin_mids_ms == pytest.approx(mids)
    p = [0.5 * np.exp(-m / 400) for m in mids]
    mdp = build_mdp(world)
    probs = mdp.split[:3]  # the three bins of "up": up, right, down, left
    assert probs[:, 0] == pytest.approx([1 - x for x in p]) and probs[:, 1] == pytest.approx([x / 3 for x in p])
    assert mdp.R_A[:3] == pytest.approx([-5 * m / 1000 for m in mids])
    assert [int(world.bin_of(d)) for d in (0, 99.9, 100, 399, 400, 3999, 4000, 9000)] == [0, 0, 1, 1, 2, 2, 2, 2]


@pytest.mark.parametrize("fields, named", [
    ({"levels": 3}, "levels"), ({"cost_per_level": 1.0}, "cost_per_level"), ({"p0": 1.5}, "p0"),
    ({"p0": -0.1}, "p0"), ({"p_inf": 0.6}, "p_inf"), ({"tau_ms": 0.0}, "tau_ms"), ({"max_hold_ms": 40.0}, "max_hold_ms"),
    ({"duration_bins_ms": [0, 500, 300, 4000]}, "duration_bins_ms"), ({"duration_bins_ms": [10, 4000]}, "duration_bins_ms"),
])
def test_a_bad_time_world_is_one_line_naming_the_field(fields, named):
    with pytest.raises(WorldError) as error:
        world_from_dict({"layout": "..G\n", "care": "time", **fields})
    message = str(error.value)
    assert "\n" not in message and f"{named}:" in message


def test_a_level_world_names_a_time_field_it_was_given():
    with pytest.raises(WorldError, match="tau_ms: only a time world"):
        world_from_dict({"layout": "..G\n", "tau_ms": 300.0})


def test_each_kind_of_world_writes_only_its_own_fields_and_reads_back_equal():
    level_keys = set(BUILTIN_WORLDS["mud"].model_dump())
    assert {"levels", "cost_per_level", "slip"} <= level_keys and not level_keys & {"care", "p0", "tau_ms", "bin"}
    time_keys = set(MUD_TIME.model_dump())
    assert not time_keys & {"levels", "cost_per_level", "slip"} and {"care", "p0", "duration_bins_ms"} <= time_keys
    for world in (MUD_TIME, BUILTIN_WORLDS["mud"]):
        assert World.model_validate(world.model_dump(mode="json")) == world
        assert World.model_validate(tomllib.loads(world.to_toml())) == world


class _Steps:
    def __init__(self) -> None:
        self.steps: list = []

    def write_step(self, step) -> None:
        self.steps.append(step)

    def end_episode(self, end) -> None:
        pass


def test_a_hold_slips_with_the_curve_at_its_exact_length_and_costs_it():
    sink = _Steps()
    game = Game(MUD_TIME, seed=3, sink=sink)
    slips = {150.0: 0, 1500.0: 0}
    n = 4000
    for hold in slips:
        for _ in range(n):
            game.live = False
            game.begin_episode()
            result = game.move("up", None, hold_ms=hold, exact=True)
            slips[hold] += result.step.slipped
            assert result.step.carefulness is None and result.step.bin == int(MUD_TIME.bin_of(hold))
            start_reward = MUD_TIME.reward_of(MUD_TIME.symbol(result.step.state))
            assert result.step.reward == pytest.approx(start_reward - 5 * hold / 1000)
    for hold, count in slips.items():
        p = 0.5 * np.exp(-hold / 400)
        assert abs(count / n - p) < 4 * np.sqrt(p * (1 - p) / n) + 1e-3
    with pytest.raises(ValueError):
        game.move("up", 3)


def test_a_simulated_time_expert_is_read_back_with_null_carefulness_and_its_bins(tmp_path: Path):
    mdp = build_mdp(MUD_TIME)
    path = tmp_path / "expert.jsonl"
    simulate_to_file(path, mdp, optimal_policy(mdp), episodes=50, seed=1, player="expert:optimal")
    step = json.loads(path.read_text().splitlines()[1])
    assert step["carefulness"] is None and step["hold_exact"] is True
    assert step["bin"] == int(MUD_TIME.bin_of(step["hold_ms"]))
    recording = read_recording(path)
    assert recording.world == MUD_TIME and recording.steps[0].level == step["bin"] + 1
    demonstrations = Demonstrations.from_recordings([recording])
    assert demonstrations.counts.sum() == len(recording.steps)
    # The expert holds longest beside the cliff (the row above it), shortest far from it.
    by_row: dict[int, list[float]] = {}
    for s in recording.steps:
        by_row.setdefault(s.state[0], []).append(float(s.hold_ms or 0))
    assert np.mean(by_row[2]) > 2 * np.mean(by_row[0])


@pytest.mark.parametrize("change, field", [
    ({"hold_ms": 4500.0}, "hold_ms"), ({"hold_ms": -1.0}, "hold_ms"), ({"bin": 2}, "bin"),
    ({"carefulness": 3}, "carefulness"), ({"hold_ms": None}, "hold_ms"),
])
def test_a_bad_time_step_is_one_line_naming_file_line_and_field(tmp_path: Path, change, field):
    mdp = build_mdp(MUD_TIME)
    good = tmp_path / "good.jsonl"
    simulate_to_file(good, mdp, optimal_policy(mdp), episodes=3, seed=2, player="expert:optimal")
    lines = good.read_text().splitlines()
    step = json.loads(lines[1])
    if change.get("bin") == 2 and step["bin"] == 2:
        change = {"bin": 3}
    lines[1] = json.dumps({**step, **change})
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError) as error:
        read_recording(bad)
    message = str(error.value)
    assert "\n" not in message and f"{bad}:2" in message and field in message


def test_a_level_worlds_step_may_not_lack_its_carefulness(tmp_path: Path):
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    good = tmp_path / "good.jsonl"
    simulate_to_file(good, mdp, optimal_policy(mdp), episodes=2, seed=2, player="expert:optimal")
    lines = good.read_text().splitlines()
    assert '"bin"' not in lines[1]  # a level world's files are as they were
    lines[1] = json.dumps({**json.loads(lines[1]), "carefulness": None})
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match="carefulness"):
        read_recording(bad)
