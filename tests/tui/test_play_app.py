"""The play screen driven by keys under a fake clock: moves, score, recording, quitting."""

from __future__ import annotations

from pathlib import Path

import pytest
from play_fixtures import FakeClock
from play_fixtures import run_pilot as run
from textual.pilot import Pilot
from textual.widgets import Static

from careful_tui.app import CarefulApp, make_play_app
from careful_tui.keys.kitty import KittyParser
from careful_tui.screens.calibration import CalibrationScreen
from careful_tui.screens.play import minimum_size
from careful_tui.widgets import Board, Gauge
from irl_core.play.hold import HoldProfile
from irl_core.recordings.demonstrations import Recording, read_recording
from irl_core.worlds.world import World, load_world

# A deterministic walk: start top-left, the goal is right, right, down; the cliff is right, down.
WALK = World(
    name="walk",
    layout="...\n.CG\n",
    levels=14,
    slip="none",
    start=(0, 0),
    rewards={"C": -1000.0, "G": 100.0},
)
PROFILE = HoldProfile(levels=14)
# Autorepeat period of the fake keyboard: slower than a real one (33 ms), to keep the tests
# fast, yet under the 99 ms that ends a hold after its first repeat; the live-gauge test uses 33 ms.
PERIOD = 0.08


def new_app(tmp_path: Path, world: World = WALK, **options) -> tuple[CarefulApp, FakeClock]:
    clock = FakeClock()
    app = make_play_app(world, out=tmp_path / "rec", player="tester", seed=1, clock=clock, **options)
    return app, clock


async def press_repeats(pilot: Pilot, clock: FakeClock, key: str, seconds: float) -> float:
    """Press `key` and autorepeat it (500 ms delay, 33 ms period) for `seconds`; the last repeat's time."""
    await pilot.press(key)
    if seconds < 0.5:
        return 0.0
    clock.advance(0.5)
    await pilot.press(key)
    last = 0.5
    while last + PERIOD <= seconds + 1e-9:
        clock.advance(PERIOD)
        last += PERIOD
        await pilot.press(key)
    return last


async def hold(pilot: Pilot, clock: FakeClock, key: str, seconds: float) -> float:
    """Hold `key` for about `seconds`, let go, and let the hold end; the hold_ms it should record."""
    last = await press_repeats(pilot, clock, key, seconds)
    clock.advance(1.0)
    pilot.app.first_screen.tick()
    await pilot.pause()
    return 0.0 if last == 0 else last * 1000 + PERIOD * 1000 / 2


async def measure_autorepeat(pilot: Pilot, clock: FakeClock, *, delay: float, repeats: int) -> CalibrationScreen:
    """Open the calibration screen and hold up: a press, `repeats` autorepeats from `delay` s,
    30 ms apart, then silence; the screen, showing what it measured."""
    await pilot.press("c")
    screen = pilot.app.screen
    assert isinstance(screen, CalibrationScreen)
    await pilot.press("up")
    clock.advance(delay)
    for _ in range(repeats):
        await pilot.press("up")
        clock.advance(0.03)
    clock.advance(0.5)
    screen.tick()
    await pilot.pause()
    return screen


def recording(app: CarefulApp) -> Recording:
    assert len(app.first_screen.recorder.paths) == 1
    return read_recording(app.first_screen.recorder.paths[0])


def status(app: CarefulApp) -> str:
    return str(app.query_one("#status", Static).render())


def test_an_episode_played_by_holding_keys_reaches_the_goal(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)
    holds: list[float] = []

    async def body(pilot: Pilot) -> None:
        holds.append(await hold(pilot, clock, "right", 0.2))
        holds.append(await hold(pilot, clock, "right", 1.0))
        assert app.first_screen.game.cell == (0, 2) and app.first_screen.game.live
        holds.append(await hold(pilot, clock, "down", 2.6))
        assert not app.first_screen.game.live
        assert "reached the goal" in status(app).lower()

    run(app, body)
    levels = [PROFILE.level_for(ms) for ms in holds]
    assert levels[0] == 1 and levels[1] == 5 and levels[2] == 14
    rec = recording(app)
    assert [s.direction for s in rec.steps] == ["right", "right", "down"]
    assert [s.carefulness for s in rec.steps] == levels
    assert [s.hold_ms for s in rec.steps] == pytest.approx(holds, abs=0.1)
    assert not any(s.hold_exact for s in rec.steps)
    assert rec.steps[-1].next_state == (1, 2)
    (end,) = rec.episode_ends
    assert end.outcome == "terminal" and end.terminal_symbol == "G"
    assert end.score == 200 - sum(levels) + 100 == app.first_screen.game.score
    assert rec.header.player == "tester" and rec.header.seed == 1
    assert rec.header.input == {"mode": "hold", **PROFILE.to_header()}


def test_falling_off_the_cliff_and_starting_again(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await hold(pilot, clock, "right", 0.0)
        await hold(pilot, clock, "down", 0.0)
        assert "fell off the cliff" in status(app).lower()
        # Between episodes arrows do nothing; space starts the next episode.
        await hold(pilot, clock, "right", 0.0)
        assert app.first_screen.game.episode == 0 and not app.first_screen.game.live
        await pilot.press("space")
        assert app.first_screen.game.live and app.first_screen.game.episode == 1 and app.first_screen.game.cell == (0, 0)
        assert app.first_screen.game.score == 200
        assert "Last episode (1): fell off the cliff, score -802" in status(app)

    run(app, body)
    rec = recording(app)
    assert [e.score for e in rec.episode_ends] == [200 - 2 - 1000]
    assert len(rec.steps) == 2


@pytest.mark.parametrize("key", ["q", "ctrl+c"])
def test_quitting_mid_episode_records_quit(tmp_path: Path, key: str) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await hold(pilot, clock, "right", 0.7)
        # A hold still being entered when quitting is not a move.
        await press_repeats(pilot, clock, "down", 0.6)
        await pilot.press(key)

    run(app, body)
    assert app.return_code == 0
    rec = recording(app)
    assert [(s.direction, s.carefulness) for s in rec.steps] == [("right", 3)]
    (end,) = rec.episode_ends
    assert end.outcome == "quit" and end.steps == 1 and end.score == 197.0
    assert rec.warnings == []


def test_quitting_before_any_move_records_nothing(tmp_path: Path) -> None:
    app, _ = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("q")

    run(app, body)
    assert app.first_screen.recorder.paths == [] and not (tmp_path / "rec").exists()


def test_the_gauge_and_arrow_follow_a_hold_live(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        gauge, board = app.query_one(Gauge), app.query_one(Board)
        await pilot.press("up")
        clock.advance(0.3)
        app.first_screen.tick()
        # No autorepeat yet: a tap so far, so level 1 and the next row filling.
        assert gauge.level == 1 and 1.0 < gauge.fill < 2.0
        assert board.arrow is not None and board.arrow.direction == "up"
        clock.advance(0.2)
        await pilot.press("up")
        for _ in range(20):
            clock.advance(0.033)
            await pilot.press("up")
        app.first_screen.tick()
        assert gauge.level == 6 and 6.0 <= gauge.fill < 7.0
        assert board.arrow.level == gauge.fill
        assert f"held {(0.5 + 20 * 0.033) * 1000:.0f} ms" in str(app.query_one("#hold-info", Static).render())
        # After the last repeat the gauge stops within one period, where the move will land.
        clock.advance(0.09)
        app.first_screen.tick()
        assert gauge.level == 6
        clock.advance(0.5)
        app.first_screen.tick()
        assert gauge.level is None and gauge.fill == 0 and board.arrow is None
        assert app.first_screen.game.t == 1

    run(app, body)
    assert recording(app).steps[0].carefulness == 6


def test_kitty_release_sequences_end_a_hold_exactly_and_never_crash(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)
    parser = KittyParser()

    async def feed(pilot: Pilot, data: str) -> None:
        for message in parser.feed(data):
            app.post_message(message)
        await pilot.pause()

    async def body(pilot: Pilot) -> None:
        await feed(pilot, "\x1b[1;1:3A\x1b[97;1:3u\x1b[1;1:9A")  # stray releases and junk first
        await feed(pilot, "\x1b[1;1:1C")  # press right
        clock.advance(0.5)
        for _ in range(10):
            await feed(pilot, "\x1b[1;1:2C")  # repeats
            clock.advance(0.04)
        app.first_screen.tick()
        assert app.query_one(Gauge).level == PROFILE.level_for(900.0)  # releases seen: the clock decides
        clock.advance(0.1)
        await feed(pilot, "\x1b[1;1:3C")  # release after exactly 1000 ms
        assert app.first_screen.game.t == 1
        await feed(pilot, "\x1b[1;1:2C\x1b[1;1:3C")  # a repeat after the release never starts a hold
        clock.advance(1.0)
        app.first_screen.tick()
        assert app.first_screen.game.t == 1 and app.is_running

    run(app, body)
    (step,) = recording(app).steps
    assert step.hold_exact and step.hold_ms == 1000.0 and step.carefulness == PROFILE.level_for(1000.0)


@pytest.mark.parametrize(("mode", "keys", "level"), [("tap", ["right"] * 3, 3), ("digits", ["1", "2", "right"], 12)])
def test_fallback_inputs_record_the_same_steps(tmp_path: Path, mode: str, keys: list[str], level: int) -> None:
    app, clock = new_app(tmp_path, input_mode=mode)

    async def body(pilot: Pilot) -> None:
        for key in keys:
            await pilot.press(key)
            clock.advance(0.1)
        clock.advance(1.0)
        app.first_screen.tick()
        await pilot.pause()
        assert app.first_screen.game.t == 1
        footer = str(app.query_one("#keys").render())
        assert ("tap" in footer) if mode == "tap" else ("1-9" in footer)

    run(app, body)
    rec = recording(app)
    (step,) = rec.steps
    assert step.direction == "right" and step.carefulness == level
    assert rec.header.input["mode"] == mode


def test_a_slip_is_shown(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path, world=load_world("paper"))
    seen: list[str] = []

    async def body(pilot: Pilot) -> None:
        for _ in range(30):
            if not app.first_screen.game.live:
                await pilot.press("space")
            await hold(pilot, clock, "left", 0.0)
            if app.first_screen.last_move is not None and app.first_screen.last_move.slipped:
                seen.append(status(app))
                assert app.query_one(Board).highlight == {app.first_screen.last_move.step.next_state: "#ff9f1c"}
                break

    run(app, body)
    assert seen and "slipped!" in seen[0] and "instead of left" in seen[0]


def test_calibration_before_the_first_move_goes_into_the_header(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await measure_autorepeat(pilot, clock, delay=0.4, repeats=8)
        await pilot.press("enter")
        assert not isinstance(app.screen, CalibrationScreen)
        assert app.first_screen.game.cell == (0, 0)  # calibrating moved nobody
        await hold(pilot, clock, "right", 0.0)

    run(app, body)
    profile = recording(app).header.input
    assert profile["calibrated"] is True
    assert profile["initial_delay_ms"] == pytest.approx(400.0)
    assert profile["repeat_period_ms"] == pytest.approx(30.0)
    assert app.first_screen.profile.calibrated


def test_calibration_is_offered_between_episodes_only(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path, calibrate=True)

    async def body(pilot: Pilot) -> None:
        assert isinstance(app.screen, CalibrationScreen)  # --calibrate opens it at the start
        await pilot.press("escape")
        assert not isinstance(app.screen, CalibrationScreen)
        await hold(pilot, clock, "right", 0.0)
        await pilot.press("c")
        assert not isinstance(app.screen, CalibrationScreen)  # mid-episode: refused
        await hold(pilot, clock, "down", 0.0)  # the cliff
        await pilot.press("c")
        assert isinstance(app.screen, CalibrationScreen)
        await pilot.press("escape")

    run(app, body)
    assert recording(app).header.input["calibrated"] is False


def test_a_small_terminal_asks_to_be_enlarged_and_resizing_works(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path, world=load_world("paper"))
    need = minimum_size(app.first_screen.world)
    assert need[0] <= 80 and need[1] <= 24

    async def body(pilot: Pilot) -> None:
        message = app.query_one("#too-small", Static)
        assert app.screen.has_class("-too-small") and message.display
        assert "make the window larger" in str(message.render()).lower()
        await pilot.press("right")  # moves wait for a large enough terminal
        clock.advance(1.0)
        app.first_screen.tick()
        assert app.first_screen.game.t == 0
        await pilot.resize_terminal(80, 24)
        await pilot.pause()
        assert not app.screen.has_class("-too-small") and app.query_one(Board).display
        await hold(pilot, clock, "right", 0.0)
        assert app.first_screen.game.t == 1

    run(app, body, size=(need[0] - 1, need[1]))


def test_the_command_refuses_a_folder_it_cannot_write(tmp_path: Path, capsys) -> None:
    from careful_tui.cli import main

    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["play", "--out", str(blocker)]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err
    assert main(["play", "--out", str(blocker / "recordings")]) == 2
    assert "cannot write recordings" in capsys.readouterr().err


def test_a_big_world_plays_in_a_usual_terminal_on_smaller_cells(tmp_path: Path) -> None:
    # 7x3 cells made a 24x24 world need 197x79; where they do not fit the cells shrink down to 3x1, and the
    # too-small message comes only below what those need.
    from bench.bench_people_big import walled_world

    world = walled_world(24)
    app, clock = new_app(tmp_path, world=world)
    need = minimum_size(world)
    assert need[0] <= 110 and need[1] <= 35

    async def body(pilot: Pilot) -> None:
        board = app.query_one(Board)
        assert not app.screen.has_class("-too-small")
        assert board.cell_size() == (3, 1)
        shown = "\n".join(board.render_line(y).text for y in range(board.content_size.height))
        assert shown.count("C") == world.cols - 2 and shown.count("G") == 1  # the whole cliff row is on the board
        await hold(pilot, clock, "up", 0.6)
        assert app.first_screen.game.t == 1
        await pilot.resize_terminal(need[0] - 1, need[1])
        await pilot.pause()
        assert app.screen.has_class("-too-small")
        assert f"needs {need[0]}x{need[1]}" in str(app.query_one("#too-small", Static).render())

    run(app, body, size=need)
