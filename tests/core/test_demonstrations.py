"""Recordings: the writer never overwrites and survives crashes; the reader names line and field."""

import json
from datetime import UTC, datetime

import numpy as np
import pytest

from irl_core.errors import RecordingError
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.world import BUILTIN_WORLDS


def header(world="paper", player="ada"):
    return SessionHeader(
        world=BUILTIN_WORLDS[world], player=player, created=datetime(2026, 11, 21, 12, 0, tzinfo=UTC),
        seed=1, input={"mode": "hold", "initial_delay_ms": 500.0}, app_version="test",
    )


def step(t, state, direction, c, next_state, *, episode=0, reward=None, score=200.0):
    return Step(episode=episode, t=t, state=state, direction=direction, carefulness=c, hold_ms=812.4,
                hold_exact=False, next_state=next_state, slipped=False,
                reward=-float(c) if reward is None else reward, score=score)


def write_session(path, world="paper"):
    with RecordingWriter(path, header(world)) as writer:
        writer.write_step(step(0, (2, 4), "right", 5, (2, 5), score=195.0))
        writer.write_step(step(1, (2, 5), "down", 3, (3, 5), score=192.0))
        writer.end_episode(EpisodeEnd(episode=0, outcome="terminal", terminal_symbol="G", steps=2,
                                      return_=92.0, score=292.0))
        writer.write_step(step(0, (0, 0), "right", 1, (0, 1), episode=1, score=199.0))
    return path


def lines(path):
    return path.read_text().splitlines()


def test_round_trip_in_spec_field_names(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    first, second = (json.loads(line) for line in lines(path)[:2])
    assert first["kind"] == "session" and first["schema"] == 1 and first["world"]["name"] == "paper"
    assert list(second) == ["kind", "episode", "t", "state", "direction", "carefulness", "hold_ms",
                            "hold_exact", "next_state", "slipped", "reward", "score"]
    assert json.loads(lines(path)[3])["return"] == 92.0
    recording = read_recording(path)
    assert len(recording.steps) == 3 and len(recording.episode_ends) == 1 and not recording.warnings
    assert recording.steps[0].state == (2, 4) and recording.steps[0].hold_ms == 812.4
    assert recording.episodes == [0, 1]  # the unfinished episode 1 still counts


def test_writer_refuses_to_overwrite(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    before = path.read_bytes()
    with pytest.raises(FileExistsError):
        RecordingWriter(path, header())
    assert path.read_bytes() == before


def test_each_line_is_on_disk_as_soon_as_it_is_written(tmp_path):
    writer = RecordingWriter(tmp_path / "s.jsonl", header())
    writer.write_step(step(0, (2, 4), "right", 5, (2, 5)))
    # Not closed: a crash now would keep both lines.
    assert len(read_recording(tmp_path / "s.jsonl").steps) == 1
    writer.close()


def test_create_in_names_by_time_and_player_and_never_collides(tmp_path):
    a = RecordingWriter.create_in(tmp_path / "rec", header(player="Ada L."))
    b = RecordingWriter.create_in(tmp_path / "rec", header(player="Ada L."))
    a.close(), b.close()
    assert a.path.name == "20261121-120000-Ada_L..jsonl" and a.path != b.path


def test_truncated_last_line_is_skipped_with_a_warning(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    path.write_text(path.read_text() + '{"kind": "step", "episode": 1, "t": 1, "sta')
    recording = read_recording(path)
    assert len(recording.steps) == 3
    assert recording.warnings == [f"{path}:6: the last line is truncated and was skipped"]


def _replace_line(path, number, **changes):
    rows = lines(path)
    obj = json.loads(rows[number - 1])
    obj.update(changes)
    rows[number - 1] = json.dumps(obj)
    path.write_text("\n".join(rows) + "\n")


def test_wrong_type_names_the_line_and_the_field(tmp_path):
    path = tmp_path / "s.jsonl"
    with RecordingWriter(path, header()) as writer:
        for t in range(8):
            writer.write_step(step(0, (0, 0), "right", 1, (0, 1), episode=t))
    _replace_line(path, 7, carefulness="five")
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    assert str(info.value).startswith(f"{path}:7: carefulness: ")
    assert (info.value.line, info.value.field) == (7, "carefulness")


@pytest.mark.parametrize(
    ("changes", "field", "problem"),
    [
        ({"carefulness": 15}, "carefulness", "above the world's 14 levels"),
        ({"carefulness": 0}, "carefulness", "greater than or equal to 1"),
        ({"state": [9, 9]}, "state", "outside the grid"),
        ({"next_state": [0, 3]}, "next_state", "cannot move from [0, 0] to [0, 3]"),
        ({"direction": "north"}, "direction", "'up', 'right', 'down' or 'left'"),
        ({"hold_ms": "long"}, "hold_ms", "valid number"),
        ({"slipped": "no"}, "slipped", "valid boolean"),
        ({"kind": "jump"}, "kind", "does not match any of the expected tags"),
        ({"extra": 1}, "extra", "Extra inputs are not permitted"),
    ],
)
def test_bad_step_lines(tmp_path, changes, field, problem):
    path = tmp_path / "s.jsonl"
    with RecordingWriter(path, header()) as writer:
        writer.write_step(step(0, (0, 0), "right", 1, (0, 1)))
    _replace_line(path, 2, **changes)
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    assert info.value.line == 2 and info.value.field == field and problem in info.value.problem


def test_missing_field(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    rows = lines(path)
    obj = json.loads(rows[1])
    del obj["score"]
    rows[1] = json.dumps(obj)
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(RecordingError, match=r":2: score: missing"):
        read_recording(path)


def test_unknown_schema_version_is_a_clear_error(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    _replace_line(path, 1, schema=2)
    with pytest.raises(RecordingError, match=r":1: schema: schema version 2 is not supported"):
        read_recording(path)


def test_empty_file(tmp_path):
    path = tmp_path / "empty.jsonl"
    path.write_text("")
    with pytest.raises(RecordingError, match="empty"):
        read_recording(path)


def test_first_line_must_be_the_header(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    path.write_text("\n".join(lines(path)[1:]) + "\n")
    with pytest.raises(RecordingError, match=r":1: kind: the first line must be the session header"):
        read_recording(path)


def test_bom_and_crlf_are_accepted(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes().replace(b"\n", b"\r\n"))
    assert len(read_recording(path).steps) == 3


def test_invalid_json_in_the_middle_is_an_error_not_a_warning(tmp_path):
    path = write_session(tmp_path / "s.jsonl")
    rows = lines(path)
    rows[2] = rows[2][:20]
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(RecordingError, match=r":3: not valid JSON"):
        read_recording(path)


def test_counts_and_empirical_policy(tmp_path):
    demos = Demonstrations.read([write_session(tmp_path / "a.jsonl"), write_session(tmp_path / "b.jsonl")])
    mdp = demos.mdp
    assert (demos.files, demos.episodes, demos.steps) == (2, 4, 6)
    s = mdp.state_of[(2, 4)]
    a = 1 * 14 + 4  # right, carefulness 5
    assert demos.counts[s, a] == 2 and demos.counts.sum() == 6
    np.testing.assert_allclose(demos.policy[demos.demonstrated].sum(axis=1), 1.0)
    assert demos.most_frequent[s] == a and demos.most_frequent[mdp.state_of[(1, 1)]] == -1


def test_recordings_from_different_worlds_are_refused(tmp_path):
    a = write_session(tmp_path / "a.jsonl", "paper")
    b = write_session(tmp_path / "b.jsonl", "mud")
    with pytest.raises(RecordingError, match="recorded in world 'mud'.*one world at a time"):
        Demonstrations.read([a, b])
