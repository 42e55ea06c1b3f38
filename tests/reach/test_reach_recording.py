"""Reach recordings: `careful simulate` writes one step line a trial exactly as the manual spells it, the
same seed the same bytes, never over a file; the reader reads them back and refuses a bad line in one line
naming file, line and field; the grid reader and its commands refuse a reach recording in one line."""

import json

import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.errors import RecordingError
from irl_core.recordings.reach_reader import is_reach_recording, read_reach_recording, read_reaches
from irl_core.worlds.reach import REACH_WORLDS

STEP_KEYS = ["kind", "episode", "t", "aim", "duration_ms", "endpoint", "regions", "reward", "score", "hold_exact"]


@pytest.fixture
def recording(tmp_path):
    path = tmp_path / "soft.jsonl"
    assert main(["simulate", "--world", "reach", "--policy", "boltzmann", "--episodes", "30", "--seed", "4",
                 "--out", str(path)]) == 0
    return path


def test_simulate_writes_one_step_line_a_trial(recording, capsys):
    lines = [json.loads(line) for line in recording.read_text().splitlines()]
    assert lines[0]["kind"] == "session" and lines[0]["world"]["care"] == "reach"
    assert lines[0]["player"] == "expert:boltzmann(beta=1)"
    steps = lines[1:]
    assert [list(step) for step in steps] == [STEP_KEYS] * 30
    assert [step["episode"] for step in steps] == list(range(30)) and {step["t"] for step in steps} == {0}
    world = REACH_WORLDS["reach"]
    score = 0.0
    for step in steps:
        assert step["regions"] == world.regions_holding(step["endpoint"])
        score += world.score_of(step["endpoint"], step["duration_ms"])
        assert step["score"] == pytest.approx(score) and step["hold_exact"] is True
        assert world.min_ms <= step["duration_ms"] <= world.max_ms


def test_the_same_seed_writes_the_same_bytes_and_never_over_a_file(recording, tmp_path, capsys):
    again = tmp_path / "again.jsonl"
    assert main(["simulate", "--world", "reach", "--policy", "boltzmann", "--episodes", "30", "--seed", "4",
                 "--out", str(again)]) == 0
    assert again.read_bytes() == recording.read_bytes()
    before = recording.read_bytes()
    assert main(["simulate", "--world", "reach", "--policy", "optimal", "--episodes", "3", "--seed", "4",
                 "--out", str(recording)]) == 2
    assert recording.read_bytes() == before and "never overwritten" in capsys.readouterr().err


def test_the_optimal_player_aims_at_one_point(tmp_path):
    path = tmp_path / "optimal.jsonl"
    assert main(["simulate", "--world", "reach-severe", "--policy", "optimal", "--episodes", "20", "--seed", "0",
                 "--out", str(path)]) == 0
    reaches, warnings = read_reaches([path])
    assert warnings == [] and reaches.trials == 20
    assert len({tuple(aim) for aim in reaches.aims.tolist()}) == 1 and len(set(reaches.endpoints[:, 0])) == 20


def test_a_person_like_policy_is_refused_on_a_reach_world(tmp_path, capsys):
    assert main(["simulate", "--world", "reach", "--policy", "loose", "--episodes", "3", "--seed", "0",
                 "--out", str(tmp_path / "x.jsonl")]) == 2
    assert "a reach world has the optimal, boltzmann and hand players" in capsys.readouterr().err
    assert not (tmp_path / "x.jsonl").exists()


def test_the_reader_reads_back_what_simulate_wrote(recording):
    read = read_reach_recording(recording)
    assert is_reach_recording(recording) and len(read.steps) == 30 and read.world == REACH_WORLDS["reach"]


def _with(recording, tmp_path, change):
    lines = recording.read_text().splitlines()
    lines[3] = change(json.loads(lines[3]))
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    return bad


@pytest.mark.parametrize(("change", "field", "words"), [
    (lambda s: json.dumps({**s, "endpoint": [1.0]}), "endpoint", "a pair of finite numbers"),
    (lambda s: json.dumps({**s, "endpoint": [1.0, "x"]}), "endpoint", "a pair of finite numbers"),
    (lambda s: json.dumps({**s, "endpoint": [1.0, float("nan")]}), "endpoint", "a pair of finite numbers"),
    (lambda s: json.dumps({**s, "aim": [1e400, 2]}).replace("Infinity", "1e400"), "aim", "a pair of finite numbers"),
    (lambda s: json.dumps({**s, "duration_ms": 1600.0}), "duration_ms", "outside the world's 150 to 1500 ms"),
    (lambda s: json.dumps({**s, "duration_ms": 100.0}), "duration_ms", "outside"),
    (lambda s: json.dumps({**s, "regions": ["C"]}), "regions", "lies in"),
    (lambda s: json.dumps({**s, "reward": s["reward"] + 1}), "reward", "the world scores this reach"),
    (lambda s: json.dumps({**s, "episode": 0}), "episode", "does not come after episode 1"),
    (lambda s: json.dumps({**s, "t": 1}), "t", "a trial is one reach"),
    (lambda s: json.dumps({**s, "kind": "episode_end"}), "kind", "step lines only"),
])
def test_a_bad_step_is_one_line_naming_file_line_and_field(recording, tmp_path, change, field, words):
    bad = _with(recording, tmp_path, change)
    with pytest.raises(RecordingError) as caught:
        read_reach_recording(bad)
    message = str(caught.value)
    assert message.startswith(f"{bad}:4: {field}: ") and words in message and "\n" not in message


def test_a_truncated_last_line_is_skipped_with_a_warning(recording, tmp_path):
    cut = tmp_path / "cut.jsonl"
    cut.write_bytes(recording.read_bytes()[:-40])
    read = read_reach_recording(cut)
    assert len(read.steps) == 29 and read.warnings == [f"{cut}:31: the last line is truncated and was skipped"]


def test_the_grid_commands_refuse_a_reach_recording_in_one_line(recording, capsys):
    assert main(["replay", str(recording)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and ":1: world.care: a reach recording" in error


def test_the_person_like_hand_lapses_times_by_hand_and_is_named_with_its_parameters(tmp_path, capsys):
    path = tmp_path / "hand.jsonl"
    assert main(["simulate", "--world", "reach", "--policy", "hand", "--episodes", "400", "--seed", "5",
                 "--lapse", "0.2", "--aim-sd", "3", "--spread", "2", "--out", str(path)]) == 0
    assert "--spread applies only to the person-like players of grid worlds" in capsys.readouterr().err
    header = json.loads(path.read_text().splitlines()[0])
    assert header["player"] == "person:hand(lapse=0.2, aim_sd=3, weber=0.15)"
    reaches, _ = read_reaches([path])
    world = REACH_WORLDS["reach"]
    best_aim = np.array([218.0, 84.0])  # the maximiser's (docs/reach.md)
    off = np.hypot(*(reaches.aims - best_aim).T)
    rushed = reaches.durations < 2 * world.min_ms
    wild = off > 6 * 3  # beyond 6 sd of the hand's own aim noise: aimed at random
    # half the lapses (0.2 x 400 = 80) rushed, half aimed at random (some of those land near the best aim)
    assert 25 <= rushed.sum() <= 60 and 20 <= wild.sum() <= 60 and not np.any(rushed & wild)
    steady = ~rushed & ~wild
    assert np.std(reaches.aims[steady] - best_aim, axis=0) == pytest.approx([3, 3], rel=0.2)
    # the meant duration is the longest allowed: a reach timed past it is refused and repeated, never clipped
    assert np.all(reaches.durations <= world.max_ms) and np.sum(reaches.durations == world.max_ms) == 0
    assert np.median(reaches.durations[steady]) == pytest.approx(1500 * np.exp(-0.15 * 0.6745), rel=0.05)


def test_the_hand_is_refused_on_a_grid_world_in_one_line(tmp_path, capsys):
    assert main(["simulate", "--world", "mud", "--policy", "hand", "--episodes", "3", "--seed", "0",
                 "--out", str(tmp_path / "x.jsonl")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "a player of reach worlds" in error
