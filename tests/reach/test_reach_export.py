"""Reach recordings exported (a CSV row, a Psych-DS row or a Minari episode per trial) read back to the same trials,
and careful/Reach-v0: Gymnasium's checker passes, one reach an episode, the world's own scatter and score."""

import csv
import json
import warnings

import gymnasium as gym
import minari
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import check_env

import irl_core.worlds.env  # noqa: F401  (registers careful/Reach-v0)
from careful_tui.cli import main
from irl_core.errors import WorldError
from irl_core.recordings.reach_reader import read_reach_recording
from irl_core.worlds.env import REACH_ENV_ID, ReachEnv
from irl_core.worlds.reach import REACH_WORLDS


@pytest.fixture
def recording(tmp_path):
    path = tmp_path / "hand.jsonl"
    assert main(["simulate", "--world", "reach", "--policy", "hand", "--episodes", "40", "--seed", "2",
                 "--out", str(path)]) == 0
    return path


@pytest.fixture
def datasets(tmp_path, monkeypatch):
    root = tmp_path / "minari-datasets"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    return root


def export(capsys, *args):
    code = main(["export", *map(str, args)])
    return code, capsys.readouterr().err


def trials_of(rows):
    """The rows as the trial lines' fields, numbers parsed."""
    return [{"episode": int(row["episode"]), "aim": [float(row["aim_x"]), float(row["aim_y"])],
             "duration_ms": float(row["duration_ms"]), "endpoint": [float(row["endpoint_x"]), float(row["endpoint_y"])],
             "regions": row["regions"].split(), "reward": float(row["reward"]), "score": float(row["score"]),
             "hold_exact": row["hold_exact"] == "true"} for row in rows]


def recorded(path):
    return [{key: step[key] for key in ("episode", "aim", "duration_ms", "endpoint", "regions", "reward", "score",
                                         "hold_exact")} for step in map(json.loads, path.read_text().splitlines()[1:])]


def test_csv_round_trip_gives_back_every_trial_exactly(recording, tmp_path, capsys):
    out = tmp_path / "trials.csv"
    code, err = export(capsys, recording, "--format", "csv", "--out", out)
    assert code == 0 and "wrote 40 rows (one per trial)" in err
    with open(out, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == ["file", "player", "episode", "aim_x", "aim_y", "duration_ms", "endpoint_x", "endpoint_y",
                             "regions", "reward", "score", "hold_exact"]
    assert {row["player"] for row in rows} == {"person:hand(lapse=0.1, aim_sd=4, weber=0.15)"}
    assert trials_of(rows) == recorded(recording)  # repr'd floats read back bit for bit
    before = out.read_bytes()
    code, err = export(capsys, recording, "--format", "csv", "--out", out)
    assert code == 2 and out.read_bytes() == before and "never overwrites" in err


def test_psych_ds_has_a_file_per_player_and_every_column_with_its_unit(recording, tmp_path, capsys):
    out = tmp_path / "dataset"
    assert export(capsys, recording, "--format", "psych-ds", "--out", out)[0] == 0
    description = json.loads((out / "dataset_description.json").read_text())
    assert [v["name"] for v in description["variableMeasured"]][3:6] == ["aim_x", "aim_y", "duration_ms"]
    assert all(v["unitText"] for v in description["variableMeasured"])
    (data,) = (out / "data").iterdir()
    assert data.name == "study-reach_participant-personhandlapse01aimsd4weber015_data.csv"
    with open(data, newline="", encoding="utf-8") as handle:
        assert trials_of(list(csv.DictReader(handle))) == recorded(recording)


def test_minari_round_trip_gives_back_every_trial_and_recovers_the_world(recording, datasets, capsys):
    code, err = export(capsys, recording, "--format", "minari", "--out", "careful/hand-v0")
    assert code == 0 and "40 episodes (one per trial)" in err
    dataset = minari.load_dataset("careful/hand-v0")
    steps = read_reach_recording(recording).steps
    world = REACH_WORLDS["reach"]
    assert dataset.total_episodes == dataset.total_steps == 40
    for episode, step in zip(dataset.iterate_episodes(), steps):
        assert episode.observations.tolist() == [list(world.start), list(step.endpoint)]
        assert episode.actions.tolist() == [[*step.aim, step.duration_ms]]
        assert episode.rewards.tolist() == [step.reward]
        assert episode.terminations.tolist() == [True] and episode.truncations.tolist() == [False]
        assert episode.infos["hit"][1].tolist() == [int(symbol in step.regions) for symbol in world.symbols]
    env = dataset.recover_environment()
    assert env.unwrapped.world == world
    assert export(capsys, recording, "--format", "minari", "--out", "careful/hand-v0")[0] == 2


def test_a_reach_and_a_grid_recording_are_not_exported_together(recording, tmp_path, capsys):
    grid = tmp_path / "grid.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "2", "--seed", "0",
                 "--out", str(grid)]) == 0
    capsys.readouterr()
    code, err = export(capsys, grid, recording, "--format", "csv", "--out", tmp_path / "x.csv")
    assert code == 2 and "export one kind at a time" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def test_a_bad_reach_line_stops_the_export_in_one_line_naming_file_line_and_field(recording, tmp_path, capsys):
    lines = recording.read_text().splitlines()
    lines[5] = json.dumps({**json.loads(lines[5]), "duration_ms": 1600.0})
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    code, err = export(capsys, bad, "--format", "csv", "--out", tmp_path / "x.csv")
    assert code == 2 and f"{bad}:6: duration_ms:" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def checker_warnings(env):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    return [str(w.message) for w in caught]


@pytest.mark.parametrize("name", list(REACH_WORLDS))
def test_the_checker_passes_and_warns_only_of_the_boxes_in_field_units(name):
    env = gym.make(REACH_ENV_ID, world=name)
    said = checker_warnings(env.unwrapped)
    # The two the design chose: the action in field units and ms (not [-1, 1]), and an endpoint that no bound holds.
    assert all("symmetric and normalized" in text or "infinity" in text for text in said), said
    world = REACH_WORLDS[name]
    assert env.action_space == gym.spaces.Box(np.array([0.0, 0.0, world.min_ms]),
                                              np.array([*world.field, world.max_ms]), dtype=np.float64)


def test_one_reach_is_one_episode_scored_as_the_world_scores_it():
    env = ReachEnv("reach-severe", render_mode="ansi")
    world = env.world
    obs, info = env.reset(seed=3)
    assert obs.tolist() == list(world.start) and info["duration_ms"] == 0.0
    obs, reward, terminated, truncated, info = env.step(np.array([216.0, 84.0, 1500.0]))
    endpoint = (float(obs[0]), float(obs[1]))
    assert terminated and not truncated and reward == world.score_of(endpoint, 1500.0)
    assert info["hit"].tolist() == [int(s in world.regions_holding(endpoint)) for s in world.symbols]
    assert "ended at" in env.render()
    with pytest.raises(ResetNeeded):
        env.step(np.array([216.0, 84.0, 1500.0]))


def test_endpoints_scatter_by_the_worlds_spread_law():
    env = ReachEnv("reach")
    aim, duration = np.array([200.0, 80.0]), 400.0
    ends = []
    for seed in range(3000):
        env.reset(seed=seed)
        ends.append(env.step(np.array([*aim, duration]))[0])
    sd = float(env.world.sd(aim, duration))
    assert np.std(ends, axis=0) == pytest.approx([sd, sd], rel=0.06)
    assert np.mean(ends, axis=0) == pytest.approx(aim, abs=4 * sd / np.sqrt(3000))


def test_an_action_outside_the_box_or_a_world_that_is_not_a_reach_is_refused():
    env = ReachEnv("reach")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="is not an action"):
        env.step(np.array([200.0, 80.0, 2000.0]))
    with pytest.raises(WorldError, match="no reach world named 'paper'"):
        ReachEnv("paper")
