"""Resuming a study: what a participant's folder holds decides what comes next, by hand-worked cases.

The study (conftest): worlds [paper, mud], shuffled, 1 practice and 3 main episodes per world.
Participant p01's order is [1, 0] (mud first): sha256("p01:1") is even, so Fisher-Yates swaps.
"""

import hashlib

import pytest
from study.conftest import write_block

from careful_tui.commands.replay import name_order
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.simulated import SimulatedParticipant, write_simulated_participant
from irl_core.studies.study import Study, read_protocol, world_order


def blocks(protocol):
    return [(b.world_index, b.phase, b.done, b.interrupted, b.next_episode) for b in protocol.blocks]


def test_p01_plays_mud_first():
    assert int.from_bytes(hashlib.sha256(b"p01:1").digest(), "big") % 2 == 0
    assert world_order(Study(name="s", worlds=("a", "b"), order="shuffled"), "p01") == [1, 0]


def test_an_empty_folder_starts_with_the_first_worlds_practice(study):
    protocol = read_protocol(study, "p01")
    assert protocol.order == (1, 0)
    assert not protocol.started and not protocol.problems
    assert blocks(protocol) == [(1, "practice", 0, 0, 0), (1, "main", 0, 0, 0),
                                (0, "practice", 0, 0, 0), (0, "main", 0, 0, 0)]
    nxt = protocol.next_block
    assert (nxt.position, nxt.world_index, nxt.phase, nxt.remaining) == (0, 1, "practice", 1)
    assert protocol.world(nxt).name == "mud"
    assert protocol.tag(nxt).model_dump() == {"name": "pilot", "participant": "p01", "phase": "practice",
                                              "world_index": 1}


def test_a_crash_mid_main_episode_replays_that_episode_only(study):
    write_block(study, "p01", 1, "practice", name="a.jsonl", finished=1)
    # Main of mud: episodes 0 and 1 finished, episode 2 cut off by a crash (no episode_end).
    write_block(study, "p01", 1, "main", name="b.jsonl", finished=2, then="crash")
    protocol = read_protocol(study, "p01")
    assert blocks(protocol)[:2] == [(1, "practice", 1, 0, 1), (1, "main", 2, 1, 3)]
    nxt = protocol.next_block
    # One main episode is left; the new file numbers it 3, after the interrupted 2.
    assert (nxt.world_index, nxt.phase, nxt.remaining, nxt.next_episode) == (1, "main", 1, 3)


def test_a_quit_episode_is_not_done_and_the_next_world_follows_a_finished_one(study):
    write_block(study, "p01", 1, "practice", name="a.jsonl", finished=1)
    write_block(study, "p01", 1, "main", name="b.jsonl", finished=2, then="crash")
    # Resumed: episode 3 quit with q mid-way; resumed again: episode 4 finished.
    write_block(study, "p01", 1, "main", name="c.jsonl", first=3, then="quit")
    write_block(study, "p01", 1, "main", name="d.jsonl", first=4, finished=1)
    protocol = read_protocol(study, "p01")
    assert blocks(protocol)[1] == (1, "main", 3, 2, 5)
    nxt = protocol.next_block
    assert (nxt.position, nxt.world_index, nxt.phase, nxt.remaining, nxt.next_episode) == (1, 0, "practice", 1, 0)


def test_an_interrupted_practice_episode_is_practised_again(study):
    write_block(study, "p01", 1, "practice", name="a.jsonl", finished=1)
    write_block(study, "p01", 1, "main", name="b.jsonl", finished=3)
    write_block(study, "p01", 0, "practice", name="c.jsonl", then="quit")
    nxt = read_protocol(study, "p01").next_block
    assert (nxt.world_index, nxt.phase, nxt.remaining, nxt.next_episode) == (0, "practice", 1, 1)


def test_every_block_done_is_the_end(study):
    write_block(study, "p01", 1, "practice", name="a.jsonl", finished=1)
    write_block(study, "p01", 1, "main", name="b.jsonl", finished=3)
    write_block(study, "p01", 0, "practice", name="c.jsonl", finished=1, then="crash")
    write_block(study, "p01", 0, "main", name="d.jsonl", finished=3)
    protocol = read_protocol(study, "p01")
    assert protocol.finished and protocol.next_block is None
    assert [b.remaining for b in protocol.blocks] == [0, 0, 0, 0]


def test_files_that_are_not_this_participants_are_named_and_not_counted(study):
    write_block(study, "p01", 1, "practice", name="a.jsonl", finished=1)
    # Another participant's file, lying in p01's folder, and a corrupt one.
    write_block(study, "p02", 1, "main", name="other.jsonl", finished=3)
    (study.participant_folder("p02") / "other.jsonl").rename(study.participant_folder("p01") / "other.jsonl")
    bad = study.participant_folder("p01") / "bad.jsonl"
    lines = (study.participant_folder("p01") / "a.jsonl").read_text().splitlines()
    bad.write_text("\n".join([lines[0], lines[1].replace('"carefulness": 2', '"carefulness": 0'), ""]))
    protocol = read_protocol(study, "p01")
    assert blocks(protocol)[1] == (1, "main", 0, 0, 0)
    problems = "\n".join(protocol.problems)
    assert "other.jsonl: recorded for participant 'p02', not 'p01'; left out" in problems
    assert f"{bad}:2: carefulness:" in problems


def test_fixed_order_follows_the_file(tmp_path):
    from study.conftest import write_study

    from irl_core.studies.study import load_study

    study = load_study(write_study(tmp_path, order="fixed", practice=0, episodes=2))
    protocol = read_protocol(study, "p01")
    assert blocks(protocol) == [(0, "main", 0, 0, 0), (1, "main", 0, 0, 0)]
    write_block(study, "p01", 0, "main", name="a.jsonl", finished=2)
    write_block(study, "p01", 1, "practice", name="b.jsonl", finished=1)
    protocol = read_protocol(study, "p01")
    assert (protocol.next_block.world_index, protocol.next_block.phase) == (1, "main")
    assert any("practice recording" in p for p in protocol.problems)


def test_a_file_cut_mid_line_by_a_crash_is_counted_and_not_called_left_out(study):
    """A crash mid-write leaves a truncated last line: the reader skips that line and the file's
    episodes count; the experimenter is told so, not that the file is left out."""
    from irl_core.studies.words import problems

    path = write_block(study, "p01", 1, "practice", name="a.jsonl", finished=1)
    with path.open("a") as file:
        file.write('{"kind": "step", "episode": 1, "t": 0, "sta')
    protocol = read_protocol(study, "p01")
    assert blocks(protocol)[0] == (1, "practice", 1, 0, 1)
    (problem,) = protocol.problems
    assert "a.jsonl:4: the last line is truncated" in problem and "left out" not in problem
    assert "the rest of the file is counted" in problem
    shown = " ".join(span.text for paragraph in problems(protocol) for span in paragraph)
    assert "not counted" not in shown and "the rest of the file is counted" in shown


@pytest.mark.parametrize("bad", ["", "../x", "..", ".hidden", "a/b", "a b", "report", "Report", "pooled", "Pooled",
                                 "x" * 81, "é"])
def test_participant_ids_that_cannot_be_folders_are_refused(study, bad):
    from irl_core.errors import StudyError

    with pytest.raises(StudyError, match="participant id"):
        read_protocol(study, bad)


def test_a_simulated_participants_files_replay_in_the_order_they_were_played(study):
    """`careful replay FOLDER` plays a folder in name order: a simulated participant's file names
    keep that the order of play (world by world, practice before main)."""
    who = SimulatedParticipant("p01", beta=1.0, seed=3)
    write_simulated_participant(study, who)
    in_name_order = sorted(study.participant_folder("p01").glob("*.jsonl"), key=name_order)
    played = [(header.study.world_index, header.study.phase)
              for header in (read_recording(path).header for path in in_name_order)]
    assert played == [(1, "practice"), (1, "main"), (0, "practice"), (0, "main")]
    assert read_protocol(study, "p01").finished
