"""The replay cursor: frames of steps and episode ends, moved by step, episode and to either end;
and several files watched one after another (`ReplayFiles`)."""

from __future__ import annotations

from pathlib import Path

from irl_core.recordings.demonstrations import Recording, read_recording
from irl_core.recordings.lines import EpisodeEnd, Step
from irl_core.recordings.replay_cursor import ReplayCursor, ReplayFiles, group_episodes
from irl_core.recordings.step_table import StepTable

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"


def step(episode: int, t: int, state: tuple[int, int], next_state: tuple[int, int], *,
         direction: str = "right", carefulness: int = 1, slipped: bool = False) -> Step:
    return Step(episode=episode, t=t, state=state, direction=direction, carefulness=carefulness,
                next_state=next_state, slipped=slipped, reward=-carefulness, score=200 - carefulness * (t + 1))


def end(episode: int, steps: int, outcome: str = "terminal", symbol: str | None = "G") -> EpisodeEnd:
    return EpisodeEnd(episode=episode, outcome=outcome, terminal_symbol=symbol, steps=steps,
                      return_=100.0 - steps, score=300.0 - steps)


# Episode 0: two steps to the goal. Episode 1: one step, no end (a crash). Episode 2: one step, quit.
STEPS = [
    step(0, 0, (0, 0), (0, 1)),
    step(0, 1, (0, 1), (1, 1), direction="down", carefulness=7),
    step(1, 0, (2, 2), (2, 1), direction="up", carefulness=3, slipped=True),
    step(2, 0, (0, 3), (0, 4)),
]
ENDS = [end(0, 2), end(2, 1, outcome="quit", symbol=None)]


def cursor() -> ReplayCursor:
    return ReplayCursor(group_episodes(STEPS, ENDS))


def where(c: ReplayCursor) -> tuple[int, int, str]:
    frame = c.frame
    return frame.index, frame.t, frame.phase


def test_episodes_are_grouped_with_their_ends_and_unfinished_ones_have_none() -> None:
    episodes = group_episodes(STEPS, ENDS)
    assert [e.number for e in episodes] == [0, 1, 2]
    assert [len(e.steps) for e in episodes] == [2, 1, 1]
    assert episodes[0].end == ENDS[0] and episodes[1].end is None and episodes[2].end == ENDS[1]


def test_forward_walks_each_step_before_and_after_its_move_then_the_episode_end() -> None:
    c = cursor()
    seen = [where(c)]
    while c.forward():
        seen.append(where(c))
    assert seen == [
        (0, 0, "before"), (0, 0, "after"), (0, 1, "before"), (0, 1, "after"), (0, 2, "end"),
        (1, 0, "before"), (1, 0, "after"), (1, 1, "end"),
        (2, 0, "before"), (2, 0, "after"), (2, 1, "end"),
    ]
    assert len(c) == len(seen) and c.at_end


def test_frames_place_the_player_and_carry_the_step() -> None:
    c = cursor()
    assert c.frame.player == (0, 0) and c.frame.step == STEPS[0]
    c.forward()
    assert c.frame.player == (0, 1) and c.frame.step == STEPS[0]
    c.go_to(4)
    assert c.frame.phase == "end" and c.frame.step is None
    assert c.frame.player == (1, 1) and c.frame.episode.end.terminal_symbol == "G"
    # The slip: before the move the player is where it chose "up"; after, where it went.
    c.go_to(5)
    assert c.frame.player == (2, 2) and c.frame.step.slipped
    c.forward()
    assert c.frame.player == (2, 1)
    c.forward()
    assert c.frame.phase == "end" and c.frame.episode.end is None and c.frame.player == (2, 1)


def test_moves_stop_at_either_end_and_say_so() -> None:
    c = cursor()
    assert c.at_start and not c.back() and c.position == 0
    assert c.to_end() and c.at_end and where(c) == (2, 1, "end")
    assert not c.forward() and not c.to_end() and c.at_end
    assert c.back() and where(c) == (2, 0, "after")
    assert c.to_start() and where(c) == (0, 0, "before")
    assert not c.go_to(-5) and c.go_to(99) and c.at_end


def test_next_and_previous_episode_cross_the_unfinished_episode() -> None:
    c = cursor()
    c.forward()
    assert c.next_episode() and where(c) == (1, 0, "before")
    assert c.next_episode() and where(c) == (2, 0, "before")
    # In the last episode "next" goes to its end, and then nowhere.
    assert c.next_episode() and where(c) == (2, 1, "end")
    assert not c.next_episode()
    assert c.previous_episode() and where(c) == (1, 0, "before")
    c.forward(), c.forward()
    assert where(c) == (1, 1, "end")
    assert c.previous_episode() and where(c) == (0, 0, "before")
    # In the first episode "previous" goes to its start, and then nowhere.
    c.go_to(3)
    assert c.previous_episode() and c.at_start
    assert not c.previous_episode()


def test_stepping_back_across_an_episode_boundary() -> None:
    c = cursor()
    c.go_to(5)
    assert where(c) == (1, 0, "before")
    assert c.back() and where(c) == (0, 2, "end")
    assert c.back() and where(c) == (0, 1, "after")


def test_an_unfinished_last_episode_still_ends_in_an_end_frame() -> None:
    c = ReplayCursor(group_episodes(STEPS[:3], ENDS[:1]))
    c.to_end()
    assert where(c) == (1, 1, "end") and c.frame.episode.end is None and c.frame.player == (2, 1)


def test_an_episode_with_an_end_but_no_steps_has_one_frame_without_a_player() -> None:
    c = ReplayCursor(group_episodes([], [end(0, 0, outcome="quit", symbol=None)]))
    assert len(c) == 1 and c.frame.phase == "end" and c.frame.player is None and c.frame.step is None
    assert not c.forward() and not c.next_episode() and not c.previous_episode()


def test_a_recording_without_lines_has_no_frames() -> None:
    c = ReplayCursor([])
    assert len(c) == 0 and c.frame is None
    assert not any([c.forward(), c.back(), c.next_episode(), c.previous_episode(), c.to_start(), c.to_end()])


def test_a_recorded_session_gives_two_frames_a_step_and_one_an_episode() -> None:
    recording = read_recording(SAMPLE)
    c = ReplayCursor.from_recording(recording)
    assert [e.number for e in c.episodes] == recording.episodes
    assert len(c) == 2 * len(recording.steps) + len(recording.episodes)
    c.to_end()
    assert c.frame.episode.end == recording.episode_ends[-1]
    assert c.frame.player == recording.steps[-1].next_state


def test_a_long_recording_is_replayed_without_building_its_steps(tmp_path: Path, monkeypatch) -> None:
    from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
    from irl_core.recordings.step_table import StepTable
    from irl_core.recordings.summary import summarise
    from irl_core.worlds.mdp import build_mdp
    from irl_core.worlds.world import BUILTIN_WORLDS

    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    path = write_rollouts(tmp_path / "long.jsonl", mdp, rollouts(mdp, optimal_policy(mdp), episodes=2000, seed=0),
                          player="x", seed=0)
    recording = read_recording(path)
    built = []
    real = StepTable.__getitem__
    monkeypatch.setattr(StepTable, "__getitem__", lambda self, i: built.append(i) or real(self, i))
    c = ReplayCursor.from_recording(recording)
    summary = summarise(recording)
    c.to_end()
    c.back()
    assert len(built) <= 2  # the summary's last step, the frame shown
    assert where(c) == (1999, len(c.episodes[-1].steps) - 1, "after")
    assert summary.steps == len(recording.steps) and len(c) == 2 * summary.steps + 2000


# ---------------------------------------------------------------------------- several files


def files(*recordings: Recording) -> ReplayFiles:
    return ReplayFiles(recordings)


def recording(name: str, steps: list[Step], ends: list[EpisodeEnd]) -> Recording:
    table = StepTable()
    for line in steps:
        table.append(line)
    return Recording(path=Path(name), header=read_recording(SAMPLE).header, steps=table, episode_ends=ends)


# Three steps in two episodes; one step in one episode; nothing at all (a header only).
FIRST = recording("a.jsonl", STEPS[:3], ENDS[:1])
SECOND = recording("b.jsonl", STEPS[3:], ENDS[1:])
EMPTY = recording("empty.jsonl", [], [])


def at(f: ReplayFiles) -> tuple[str, tuple[int, int, str] | None]:
    """(file name, (episode index, t, phase) in it, or None in a file without frames)."""
    return f.recording.path.name, None if f.cursor.frame is None else where(f.cursor)


def test_stepping_forward_runs_through_every_file_in_order_then_stops() -> None:
    f = files(FIRST, EMPTY, SECOND)
    seen = [at(f)]
    while f.forward():
        seen.append(at(f))
    assert seen == [
        ("a.jsonl", (0, 0, "before")), ("a.jsonl", (0, 0, "after")), ("a.jsonl", (0, 1, "before")),
        ("a.jsonl", (0, 1, "after")), ("a.jsonl", (0, 2, "end")),
        ("a.jsonl", (1, 0, "before")), ("a.jsonl", (1, 0, "after")), ("a.jsonl", (1, 1, "end")),
        ("empty.jsonl", None),
        ("b.jsonl", (0, 0, "before")), ("b.jsonl", (0, 0, "after")), ("b.jsonl", (0, 1, "end")),
    ]
    assert f.at_end and not f.forward() and at(f) == ("b.jsonl", (0, 1, "end"))
    # And back again, frame for frame, to the very first.
    back = [at(f)]
    while f.back():
        back.append(at(f))
    assert back == seen[::-1] and f.place == (0, 0)


def test_episode_keys_cross_into_the_next_and_previous_file() -> None:
    f = files(FIRST, SECOND)
    assert f.next_episode() and at(f) == ("a.jsonl", (1, 0, "before"))
    # From a file's last episode the next episode is the next file's first.
    assert f.next_episode() and at(f) == ("b.jsonl", (0, 0, "before"))
    # In the last file's last episode: to its end, then nowhere.
    assert f.next_episode() and at(f) == ("b.jsonl", (0, 1, "end"))
    assert not f.next_episode()
    # Back from a file's first episode: the previous file's last episode, at its start.
    assert f.previous_episode() and at(f) == ("a.jsonl", (1, 0, "before"))
    assert f.previous_episode() and at(f) == ("a.jsonl", (0, 0, "before"))
    assert not f.previous_episode()


def test_file_keys_go_to_a_files_start_and_stop_at_either_end() -> None:
    f = files(FIRST, SECOND)
    f.forward()
    assert f.previous_file() and f.place == (0, 0)
    assert not f.previous_file()
    assert f.next_file() and f.place == (1, 0)
    # In the last file, next file goes to its end; home and end stay in the file.
    assert f.next_file() and f.at_end and not f.next_file()
    assert f.to_start() and f.place == (1, 0)
    assert f.to_end() and f.place == (1, len(f.cursor) - 1)


def test_a_single_file_moves_as_its_cursor_does() -> None:
    f, c = files(FIRST), ReplayCursor.from_recording(FIRST)
    for move in ["forward", "next_episode", "back", "previous_episode", "to_end", "previous_episode", "to_start",
                 "next_file", "previous_file"]:
        moved = getattr(f, move)()
        expected = getattr(c, {"next_file": "to_end", "previous_file": "to_start"}.get(move, move))()
        assert (moved, f.cursor.position) == (expected, c.position), move
