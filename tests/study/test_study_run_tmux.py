"""`careful study run` in a real terminal (tmux), digits input: one participant goes through a
two-world study (1 practice and 2 main episodes per world); another is killed mid-episode
(SIGKILL) and runs again: nothing recorded is lost and no episode is played twice."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

from study.study_run_files import write_study
from tmux_terminal import Terminal, needs_tmux, terminal

from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study, read_protocol

pytestmark = needs_tmux

# (world_index, phase) in the participant's sequence (order fixed) and the level typed for each
# of its episodes; every episode is one move ("right" reaches the goal, "left" the cliff).
SEQUENCE = [((0, "practice"), "3"), ((0, "main"), "24"), ((1, "practice"), "9"), ((1, "main"), "15")]
ENDING_KEY = {0: "Right", 1: "Left"}


def study_run(tmp_path: Path, participant: str):
    return terminal(tmp_path, ["study", "run", "pilot.toml", "--participant", participant])


def play_episode(session: Terminal, world_index: int, level: str) -> None:
    session.send(level)
    session.send(ENDING_KEY[world_index])
    session.wait_for(lambda screen: "Press space for the next episode." in screen or "Press space to go on." in screen)


def play_blocks(session: Terminal, blocks: list[tuple[tuple[int, str], str]]) -> None:
    """Play whole blocks from a screen that waits for space (instructions or between blocks)."""
    for (world_index, phase), levels in blocks:
        session.send("Space")
        word = "Practice episode" if phase == "practice" else "Episode"
        for i, level in enumerate(levels):
            if i:
                session.send("Space")
            session.wait_for(f"{word} {i + 1} of {len(levels)}")
            play_episode(session, world_index, level)
        session.wait_for("Press space to go on.")
        session.send("Space")
        session.wait_for(lambda screen: "Practice is over." in screen or "is done." in screen
                         or "That is the end of the study" in screen)


def lines_of(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def blocks_on_disk(folder: Path) -> dict[tuple[int, str], list]:
    blocks: dict[tuple[int, str], list] = {}
    for path in sorted(folder.glob("*.jsonl")):
        recording = read_recording(path)
        tag = recording.header.study
        blocks.setdefault((tag.world_index, tag.phase), []).append(recording)
    return blocks


def finished(recordings: list) -> dict[int, int]:
    """Finished episode number -> its one step's carefulness, over a block's files."""
    done = {}
    for recording in recordings:
        ends = {end.episode for end in recording.episode_ends if end.outcome == "terminal"}
        for step in recording.steps:
            if step.episode in ends:
                assert step.episode not in done, f"episode {step.episode} finished twice"
                done[step.episode] = step.carefulness
    return done


def test_a_participant_goes_through_the_study_and_a_killed_one_resumes_without_loss_or_repeats(tmp_path: Path) -> None:
    path = write_study(tmp_path)
    study = load_study(path)
    data = tmp_path / "data"

    # p01: the whole study in one run.
    with study_run(tmp_path, "p01") as session:
        session.wait_for("Press space to begin.")
        play_blocks(session, SEQUENCE)
        session.send("Space")
        assert session.wait_exit() == 0
        assert "participant p01 has finished study 'pilot'" in session.history()
    blocks = blocks_on_disk(data / "p01")
    assert sorted(blocks) == sorted(key for key, _ in SEQUENCE)
    for (world_index, phase), levels in SEQUENCE:
        (recording,) = blocks[(world_index, phase)]
        header = recording.header
        assert header.player == "p01" and header.input["mode"] == "digits"
        assert header.study.model_dump() == {"name": "pilot", "participant": "p01", "phase": phase,
                                             "world_index": world_index}
        assert header.world == study.worlds[world_index]
        assert finished([recording]) == {i: int(level) for i, level in enumerate(levels)}
        assert [end.outcome for end in recording.episode_ends] == ["terminal"] * len(levels)

    # p02: killed by SIGKILL in world 0's second main episode, after one move of it.
    with study_run(tmp_path, "p02") as session:
        session.wait_for("Press space to begin.")
        play_blocks(session, SEQUENCE[:1])
        session.send("Space")
        session.wait_for("Episode 1 of 2")
        play_episode(session, 0, "2")
        session.send("Space")
        session.wait_for("Episode 2 of 2")
        session.send("7")
        session.send("Up")  # into the top edge: the episode goes on
        session.wait_for("step 1/200")
        os.kill(session.pid(), signal.SIGKILL)
        assert session.wait_exit() == 128 + signal.SIGKILL
    (cut,) = blocks_on_disk(data / "p02")[(0, "main")]
    before_kill = {p: p.read_bytes() for p in (data / "p02").glob("*.jsonl")}
    assert [(line["kind"], line.get("episode")) for line in lines_of(cut.path)] == [
        ("session", None), ("step", 0), ("episode_end", 0), ("step", 1)]  # the killed episode: no end
    protocol = read_protocol(study, "p02")
    assert [(b.done, b.interrupted, b.next_episode) for b in protocol.blocks] == [(1, 0, 1), (1, 1, 2), (0, 0, 0), (0, 0, 0)]

    # p02 again: goes on with the episode that was cut off, numbered after it, then the rest.
    with study_run(tmp_path, "p02") as session:
        session.wait_for("Welcome back: 2 of 6 episodes are done.")
        # The greeting's lines may be drawn in more than one frame: wait for the one asserted.
        session.wait_for(lambda screen: "You go on with: World 1 of 2 (right): episode 2 of 2." in " ".join(screen.split()))
        session.send("Space")
        session.wait_for("Episode 2 of 2")
        play_episode(session, 0, "4")
        session.wait_for("Press space to go on.")
        session.send("Space")
        session.wait_for("World 1 of 2 is done.")
        play_blocks(session, SEQUENCE[2:])
        session.send("Space")
        assert session.wait_exit() == 0
    for file, content in before_kill.items():
        assert file.read_bytes() == content  # nothing recorded before the kill changed
    blocks = blocks_on_disk(data / "p02")
    assert finished(blocks[(0, "practice")]) == {0: 3}
    assert finished(blocks[(0, "main")]) == {0: 2, 2: 4}  # episode 1 was cut off; its number is not reused
    assert finished(blocks[(1, "practice")]) == {0: 9}
    assert finished(blocks[(1, "main")]) == {0: 1, 1: 5}
    assert len(blocks[(0, "main")]) == 2 and all(len(blocks[key]) == 1 for key in blocks if key != (0, "main"))
    assert read_protocol(study, "p02").finished
    assert [(b.done, b.target) for b in read_protocol(study, "p02").blocks] == [(1, 1), (2, 2), (1, 1), (2, 2)]


def test_sigterm_before_the_first_episode_leaves_cleanly_and_creates_nothing(tmp_path: Path) -> None:
    write_study(tmp_path)
    with study_run(tmp_path, "p03") as session:
        session.wait_for("Press space to begin.")
        os.kill(session.pid(), signal.SIGTERM)
        assert session.wait_exit() == 0
        assert "participant p03: 0 of 6 episodes of study 'pilot' done; run the same command to go on" in session.history()
    assert not (tmp_path / "data" / "p03").exists()
