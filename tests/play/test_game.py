"""The game's rules without a screen: moves, score, episode ends and what gets recorded."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from irl_core.errors import GameOver
from irl_core.play.game import Game
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import SessionRecorder, check_writable
from irl_core.worlds.mdp import DIRECTIONS, OFFSETS
from irl_core.worlds.world import World, load_world

TINY = World(
    name="tiny",
    layout="...\n.CG\n",
    levels=3,
    cost_per_level=2.0,
    slip="none",
    start=(0, 0),
    rewards={"C": -1000.0, "G": 100.0},
)


class ListSink:
    def __init__(self) -> None:
        self.lines: list[Step | EpisodeEnd] = []

    def write_step(self, step: Step) -> None:
        self.lines.append(step)

    def end_episode(self, end: EpisodeEnd) -> None:
        self.lines.append(end)


def header(world: World, **changes) -> SessionHeader:
    return SessionHeader(world=world, player="tester", created=datetime(2024, 1, 1, tzinfo=UTC),
                         seed=0, **changes)


def test_reaching_the_goal_scores_every_step_and_the_goal() -> None:
    sink = ListSink()
    game = Game(TINY, seed=0, sink=sink)
    assert game.begin_episode() == (0, 0)
    game.move("right", 1, hold_ms=0.0)
    game.move("right", 3, hold_ms=812.44)
    result = game.move("down", 2, hold_ms=650.0, exact=True)

    assert result.end is not None and result.end.outcome == "terminal" and result.end.terminal_symbol == "G"
    expected = 200 - 2 * (1 + 3 + 2) + 100
    assert game.score == result.end.score == expected
    assert result.end.return_ == expected - 200 and result.end.steps == 3
    steps = [line for line in sink.lines if isinstance(line, Step)]
    assert [s.state for s in steps] == [(0, 0), (0, 1), (0, 2)]
    assert [s.next_state for s in steps] == [(0, 1), (0, 2), (1, 2)]
    assert [s.reward for s in steps] == [-2.0, -6.0, -4.0]
    assert [s.score for s in steps] == [198.0, 192.0, 188.0]
    assert steps[1].hold_ms == 812.4 and steps[2].hold_exact
    assert not game.live and game.last_end == result.end


def test_falling_off_the_cliff_ends_with_its_penalty() -> None:
    game = Game(TINY, seed=0, sink=ListSink())
    game.begin_episode()
    game.move("right", 1)
    result = game.move("down", 1)
    assert result.end is not None and result.end.terminal_symbol == "C"
    assert result.end.score == 200 - 2 - 2 - 1000


def test_the_step_limit_truncates_an_episode() -> None:
    world = TINY.model_copy(update={"max_steps": 3})
    game = Game(world, seed=0, sink=ListSink())
    game.begin_episode()
    ends = [game.move("up", 1).end for _ in range(3)]
    assert ends[:2] == [None, None]
    assert ends[2] is not None and ends[2].outcome == "step_limit" and ends[2].terminal_symbol is None
    assert game.cell == (0, 0) and ends[2].score == 200 - 3 * 2


def test_quit_records_a_played_episode_and_nothing_for_an_unplayed_one() -> None:
    sink = ListSink()
    game = Game(TINY, seed=0, sink=sink)
    game.begin_episode()
    assert game.quit() is None and sink.lines == []
    game.begin_episode()
    assert game.episode == 0
    game.move("right", 2)
    end = game.quit()
    assert end is not None and end.outcome == "quit" and end.steps == 1 and end.score == 196.0
    assert sink.lines[-1] == end
    assert game.quit() is None
    with pytest.raises(GameOver):
        game.move("right", 1)


def test_episodes_are_numbered_and_scores_restart() -> None:
    sink = ListSink()
    game = Game(TINY, seed=0, sink=sink)
    for episode in range(3):
        game.begin_episode()
        assert game.episode == episode and game.score == 200
        game.move("right", 1)
        game.move("down", 1)
    assert [line.episode for line in sink.lines if isinstance(line, EpisodeEnd)] == [0, 1, 2]


def test_bad_intents_are_refused() -> None:
    game = Game(TINY, seed=0, sink=ListSink())
    game.begin_episode()
    with pytest.raises(ValueError):
        game.move("north", 1)
    with pytest.raises(ValueError):
        game.move("up", 4)
    with pytest.raises(GameOver):
        game.begin_episode()


def test_slips_follow_the_world_and_the_seed() -> None:
    world = load_world("paper")

    def play(seed: int) -> list[Step]:
        sink = ListSink()
        game = Game(world, seed=seed, sink=sink)
        while len(sink.lines) < 400:
            if not game.live:
                game.begin_episode()
            game.move("up", 1)
        return [line for line in sink.lines if isinstance(line, Step)]

    steps = play(7)
    assert steps == play(7)
    # Level 1 goes the chosen way with probability 1/2.
    assert 0.4 < np.mean([s.slipped for s in steps]) < 0.6
    for s in steps:
        # The next cell is one step in some direction (or the same cell at an edge).
        moves = {(s.state[0] + dr, s.state[1] + dc) for dr, dc in OFFSETS} | {s.state}
        assert s.next_state in moves
        if not s.slipped:
            assert s.next_state == (max(0, s.state[0] - 1), s.state[1])
    assert all(s.direction in DIRECTIONS for s in steps)


def test_session_recorder_creates_the_file_at_the_first_line(tmp_path: Path) -> None:
    recorder = SessionRecorder(tmp_path / "out", header(TINY, input={"mode": "hold"}))
    game = Game(TINY, seed=0, sink=recorder)
    game.begin_episode()
    assert recorder.path is None and not (tmp_path / "out").exists()
    recorder.set_header(header(TINY, input={"mode": "hold", "calibrated": True}))
    game.move("right", 2, hold_ms=700.0)
    first = recorder.path
    assert first is not None and first.parent == tmp_path / "out" and first.name.endswith("-tester.jsonl")
    game.move("down", 1, hold_ms=0.0)

    # A header change after lines were written starts a new session file.
    recorder.set_header(header(TINY, input={"mode": "hold", "calibrated": False}))
    game.begin_episode()
    game.move("right", 3, hold_ms=1100.0)
    game.quit()
    recorder.close()
    assert len(recorder.paths) == 2 and recorder.paths[0] == first

    one, two = (read_recording(p) for p in recorder.paths)
    assert one.header.input["calibrated"] is True and two.header.input["calibrated"] is False
    assert [(s.episode, s.carefulness, s.hold_ms) for s in one.steps] == [(0, 2, 700.0), (0, 1, 0.0)]
    assert [e.outcome for e in one.episode_ends] == ["terminal"]
    assert [(s.episode, s.carefulness) for s in two.steps] == [(1, 3)]
    assert [e.outcome for e in two.episode_ends] == ["quit"]
    assert one.header.created.tzinfo is not None


def test_check_writable(tmp_path: Path) -> None:
    check_writable(tmp_path / "new" / "folder")
    assert (tmp_path / "new" / "folder").is_dir() and not any((tmp_path / "new" / "folder").iterdir())
    (tmp_path / "file").write_text("x")
    with pytest.raises(OSError):
        check_writable(tmp_path / "file")
