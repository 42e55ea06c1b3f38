"""The replay screen driven by keys: steps, episodes, playing by `advance`, warnings, bad files."""

from __future__ import annotations

import asyncio
import io
from collections.abc import Awaitable, Callable
from datetime import UTC, datetime
from pathlib import Path

import pytest
from rich.console import Console
from textual.pilot import Pilot
from textual.widgets import Static

from careful_tui.app import CarefulApp, make_replay_app
from careful_tui.cli import main
from careful_tui.screens.replay import END_TICKS, minimum_size
from careful_tui.widgets import Board, Gauge
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, Step
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.world import World

# Start top-left; the goal is right, right, down; the cliff is right, down.
WALK = World(name="walk", layout="...\n.CG\n", levels=14, start=(0, 0), rewards={"C": -1000.0, "G": 100.0})
HEADER = SessionHeader(world=WALK, player="tester", created=datetime(2026, 1, 2, 3, 4, tzinfo=UTC),
                       seed=0, input={"mode": "hold"})
# (episode, state, direction, level, hold_ms, exact, next_state, slipped)
MOVES = [
    (0, (0, 0), "right", 1, 120.0, False, (0, 1), False),
    (0, (0, 1), "right", 5, 812.4, True, (0, 2), False),
    (0, (0, 2), "down", 14, 2600.0, False, (1, 2), False),
    (1, (0, 0), "right", 2, 400.0, False, (0, 1), False),
    (1, (0, 1), "down", 1, 90.0, False, (1, 1), False),
    (2, (0, 0), "right", 3, 600.0, False, (1, 0), True),
]
ENDS = {0: ("terminal", "G"), 1: ("terminal", "C")}  # episode 2 never ends: the file stops


def write_walk(path: Path, *, truncate: bool = False) -> Path:
    score, t, last = 200.0, 0, None
    with RecordingWriter(path, HEADER) as writer:
        for episode, state, direction, level, hold_ms, exact, next_state, slipped in MOVES:
            if episode != last:
                score, t, last = 200.0, 0, episode
            score -= level
            writer.write_step(Step(episode=episode, t=t, state=state, direction=direction, carefulness=level,
                                   hold_ms=hold_ms, hold_exact=exact, next_state=next_state, slipped=slipped,
                                   reward=-float(level), score=score))
            t += 1
            if episode in ENDS and next_state in ((1, 1), (1, 2)):
                outcome, symbol = ENDS[episode]
                final = score + WALK.rewards[symbol]
                writer.end_episode(EpisodeEnd(episode=episode, outcome=outcome, terminal_symbol=symbol, steps=t,
                                              return_=final - 200, score=final))
    if truncate:
        with open(path, "a", encoding="utf-8") as file:
            file.write('{"kind": "step", "episode": 2, "t": 1, "sta')
    return path


def run(app: CarefulApp, body: Callable[[Pilot], Awaitable[None]], size=(100, 35)) -> None:
    async def go() -> None:
        async with app.run_test(size=size, notifications=True) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(go())


def new_app(path: Path) -> CarefulApp:
    # A frame lasts longer than any test: the timer never fires, the tests call advance().
    return make_replay_app(read_recording(path), frame_seconds=3600)


def text(app: CarefulApp, selector: str) -> str:
    console = Console(width=200, record=True, file=io.StringIO())
    console.print(app.query_one(selector, Static).content)
    return console.export_text()


def view(app: CarefulApp) -> tuple:
    """(player cell, arrow direction or None, gauge level, slip-highlighted cells)."""
    board, gauge = app.query_one(Board), app.query_one(Gauge)
    return board.player, None if board.arrow is None else board.arrow.direction, gauge.level, set(board.highlight)


def test_arrow_keys_step_through_moves_and_the_episode_end(tmp_path: Path) -> None:
    app = new_app(write_walk(tmp_path / "walk.jsonl"))

    async def body(pilot: Pilot) -> None:
        assert view(app) == ((0, 0), "right", 1, set())
        assert "held 120 ms" in text(app, "#hold-info") and "exact" not in text(app, "#hold-info")
        await pilot.press("right")
        assert view(app) == ((0, 1), None, 1, set())
        await pilot.press("right")
        assert view(app) == ((0, 1), "right", 5, set())
        assert "held 812 ms exact" in text(app, "#hold-info")
        assert "step 2/3" in text(app, "#status")
        await pilot.press("right", "right")
        assert view(app) == ((0, 2), "down", 14, set())
        await pilot.press("right", "right")
        assert view(app) == ((1, 2), None, None, set())
        status = text(app, "#status")
        assert "reached the goal!" in status and "score 280" in status
        await pilot.press("left")
        assert view(app) == ((1, 2), None, 14, set())

    run(app, body)


def test_episode_keys_jump_between_episodes_and_home_end_to_either_end(tmp_path: Path) -> None:
    app = new_app(write_walk(tmp_path / "walk.jsonl"))

    async def body(pilot: Pilot) -> None:
        await pilot.press("right")
        await pilot.press("up")
        assert app.first_screen.cursor.frame.index == 1 and view(app) == ((0, 0), "right", 2, set())
        assert "Episode 2/3" in text(app, "#status")
        await pilot.press("n")
        assert app.first_screen.cursor.frame.index == 2 and view(app) == ((0, 0), "right", 3, set())
        # The slip: the arrow says right, the player lands below, framed in the slip colour.
        await pilot.press("right")
        assert view(app) == ((1, 0), None, 3, {(1, 0)})
        assert "slipped! went down instead of right" in text(app, "#status")
        await pilot.press("right")
        assert "unfinished" in text(app, "#status") and app.first_screen.cursor.at_end
        await pilot.press("down")
        assert app.first_screen.cursor.frame.index == 1 and app.first_screen.cursor.frame.t == 0
        await pilot.press("p")
        assert app.first_screen.cursor.at_start
        await pilot.press("end")
        assert app.first_screen.cursor.at_end and view(app)[0] == (1, 0)
        await pilot.press("home")
        assert app.first_screen.cursor.at_start and view(app) == ((0, 0), "right", 1, set())

    run(app, body)


def test_space_plays_with_advance_and_pauses(tmp_path: Path) -> None:
    app = new_app(write_walk(tmp_path / "walk.jsonl"))

    async def body(pilot: Pilot) -> None:
        app.first_screen.advance()
        assert app.first_screen.cursor.position == 0, "paused: advance does nothing"
        await pilot.press("space")
        assert app.first_screen.playing and "playing" in text(app, "#status")
        app.first_screen.advance()
        app.first_screen.advance()
        await pilot.pause()
        assert app.first_screen.cursor.position == 2 and view(app)[:3] == ((0, 1), "right", 5)
        await pilot.press("space")
        assert not app.first_screen.playing and "paused" in text(app, "#status")
        app.first_screen.advance()
        assert app.first_screen.cursor.position == 2
        # Playing on: an episode's end stays on screen for END_TICKS ticks.
        await pilot.press("space")
        for _ in range(4):
            app.first_screen.advance()
        assert app.first_screen.cursor.frame.phase == "end"
        for _ in range(END_TICKS - 1):
            app.first_screen.advance()
            assert app.first_screen.cursor.frame.phase == "end"
        app.first_screen.advance()
        assert app.first_screen.cursor.frame.index == 1
        # Playback stops at the last frame; space there starts again from the first.
        for _ in range(50):
            app.first_screen.advance()
        assert app.first_screen.cursor.at_end and not app.first_screen.playing
        await pilot.press("space")
        assert app.first_screen.playing and app.first_screen.cursor.at_start

    run(app, body)


def test_the_timer_plays_on_its_own(tmp_path: Path) -> None:
    app = make_replay_app(read_recording(write_walk(tmp_path / "walk.jsonl")), playing=True, frame_seconds=0.01)

    async def body(pilot: Pilot) -> None:
        for _ in range(200):
            if app.first_screen.cursor.at_end:
                break
            await asyncio.sleep(0.01)
        assert app.first_screen.cursor.at_end and not app.first_screen.playing

    run(app, body)


def test_plus_and_minus_change_the_speed_and_show_it(tmp_path: Path) -> None:
    app = new_app(write_walk(tmp_path / "walk.jsonl"))

    async def body(pilot: Pilot) -> None:
        assert app.first_screen.speed == 1 and "speed ×1" in text(app, "#status")
        await pilot.press("plus", "plus")
        assert app.first_screen.speed == 4 and "speed ×4" in text(app, "#status")
        await pilot.press("minus", "minus", "minus")
        assert app.first_screen.speed == 0.5 and "speed ×0.5" in text(app, "#status")
        for _ in range(10):
            await pilot.press("minus")
        assert app.first_screen.speed == 0.25

    run(app, body)


def test_the_panel_summarises_the_session(tmp_path: Path) -> None:
    app = new_app(write_walk(tmp_path / "walk.jsonl"))

    async def body(pilot: Pilot) -> None:
        panel = text(app, "#summary")
        for expected in ("tester", "world walk", "input hold", "2026-01-02 03:04", "3 episodes",
                         "1 reached the goal", "1 fell off the cliff", "1 unfinished", "6 steps", "1 slip",
                         "197 final score", "carefulness by", "distance to C/G"):
            assert expected in panel, expected

    run(app, body)


def test_a_truncated_recording_opens_with_its_warning_shown(tmp_path: Path) -> None:
    path = write_walk(tmp_path / "walk.jsonl", truncate=True)
    app = new_app(path)
    assert app.first_screen.recording.warnings

    async def body(pilot: Pilot) -> None:
        assert "line 10: the last line is truncated and was skipped" in text(app, "#summary")
        assert [n.message for n in app._notifications] == app.first_screen.recording.warnings
        await pilot.press("end")
        assert "unfinished" in text(app, "#status")

    run(app, body)


def test_a_recording_without_steps_opens_and_says_so(tmp_path: Path) -> None:
    path = tmp_path / "empty.jsonl"
    RecordingWriter(path, HEADER).close()
    app = new_app(path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("right", "up", "end", "space")
        assert "no steps" in text(app, "#status") and not app.first_screen.playing
        assert view(app) == (None, None, None, set())

    run(app, body)


def test_a_small_terminal_asks_to_be_enlarged(tmp_path: Path) -> None:
    app = new_app(write_walk(tmp_path / "walk.jsonl"))

    async def body(pilot: Pilot) -> None:
        assert app.screen.has_class("-too-small")
        assert "careful replay needs" in text(app, "#too-small")
        await pilot.resize_terminal(80, 24)
        await pilot.pause()
        assert not app.screen.has_class("-too-small")

    run(app, body, size=(50, 20))


def test_80x24_is_enough_for_the_paper_world() -> None:
    sample = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"
    width, height = minimum_size(read_recording(sample).world)
    assert width <= 80 and height <= 24


@pytest.mark.parametrize("content, expected", [
    ('{"kind": "step"}\n', "bad.jsonl:1: kind: the first line must be the session header"),
    ("", "bad.jsonl: the file is empty"),
])
def test_a_bad_recording_exits_2_with_one_line(tmp_path: Path, capsys, content: str, expected: str) -> None:
    path = tmp_path / "bad.jsonl"
    path.write_text(content)
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err
    assert expected in err and err.count("\n") == 1 and "Traceback" not in err


def test_a_missing_file_exits_2(tmp_path: Path, capsys) -> None:
    assert main(["replay", str(tmp_path / "nope.jsonl")]) == 2
    err = capsys.readouterr().err
    assert "nope.jsonl: cannot read the file" in err and err.count("\n") == 1


def test_a_good_recording_without_a_terminal_exits_2(tmp_path: Path, capsys) -> None:
    assert main(["replay", str(write_walk(tmp_path / "walk.jsonl"))]) == 2
    assert "careful replay needs an interactive terminal" in capsys.readouterr().err


@pytest.mark.parametrize(("realised", "shown"), [
    ("up", "slipped! went up into the edge instead of right"),
    (None, "slipped! stayed put instead of going right"),  # an older file: no direction to read
])
def test_a_slip_into_the_edge_is_shown_with_the_way_it_went(tmp_path: Path, realised, shown) -> None:
    path = tmp_path / "edge.jsonl"
    with RecordingWriter(path, HEADER) as writer:
        writer.write_step(Step(episode=0, t=0, state=(0, 0), direction="right", carefulness=1, hold_ms=100.0,
                               next_state=(0, 0), slipped=True, reward=-1.0, score=199.0, realised=realised))
    app = new_app(path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("right")
        assert view(app)[0] == (0, 0)
        assert shown in text(app, "#status")

    run(app, body)


def test_a_big_worlds_replay_shows_its_whole_board_at_the_least_size_it_asks_for(tmp_path: Path) -> None:
    # The board's column gets three quarters of the room beside the gauge (the session panel the rest): at the
    # size the replay asks for, a 24x24 world's board of 3x1 cells is whole, its goal in the last column.
    from bench.bench_people_big import walled_world
    from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
    from irl_core.worlds.mdp import build_mdp

    mdp = build_mdp(walled_world(24))
    path = write_rollouts(tmp_path / "big.jsonl", mdp, rollouts(mdp, optimal_policy(mdp), episodes=1, seed=0),
                          player="tester", seed=0)
    app = new_app(path)
    need = minimum_size(mdp.world)

    async def body(pilot: Pilot) -> None:
        board = app.query_one(Board)
        assert not app.screen.has_class("-too-small") and board.cell_size() == (3, 1)
        assert board.content_size.width >= 3 * 24
        shown = "\n".join(board.render_line(y).text for y in range(board.content_size.height))
        assert shown.count("G") == 1

    run(app, body, size=need)
