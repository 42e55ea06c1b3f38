"""The reach screen driven by keys under a fake clock: the aim, the ring while space is held, a trial launched
and recorded, a refusal shown and not recorded, kitty's exact releases, a block's end, a small window."""

from __future__ import annotations

from pathlib import Path

import pytest
from play_fixtures import FakeClock
from play_fixtures import run_pilot as run
from textual.pilot import Pilot
from textual.widgets import Static

from careful_tui.app import CarefulApp, make_reach_app
from careful_tui.keys.kitty import KittyParser
from careful_tui.widgets.reach_field import ReachField
from irl_core.recordings.reach_reader import read_reach_recording
from irl_core.worlds.reach import REACH_WORLDS

WORLD = REACH_WORLDS["reach"]
PERIOD = 0.05


def new_app(tmp_path: Path, *, trials: int = 3) -> tuple[CarefulApp, FakeClock]:
    clock = FakeClock()
    app = make_reach_app(WORLD, out=tmp_path / "rec", player="tester", seed=5, trials=trials, clock=clock,
                         event_times=False)
    return app, clock


def panel(app: CarefulApp) -> str:
    return str(app.query_one("#reach-panel", Static).render())


async def press_repeats(pilot: Pilot, clock: FakeClock, repeats: int) -> None:
    """Space pressed, then `repeats` autorepeats from 500 ms, `PERIOD` apart, as a legacy terminal sends them."""
    await pilot.press("space")
    clock.advance(0.5)
    for k in range(repeats):
        if k:
            clock.advance(PERIOD)
        await pilot.press("space")


async def let_go(pilot: Pilot, clock: FakeClock) -> None:
    """Silence until the hold ends (a tap waits 1.5 s for a first repeat), and the screen's tick that launches it."""
    clock.advance(2.0)
    # A tick defers while a message waits in the app's queue (a key, maybe); on a busy machine one often does,
    # so tick until the hold has ended (the clock stands still: the silence is the same each time).
    for _ in range(200):
        pilot.app.first_screen.tick()
        await pilot.pause()
        if not pilot.app.first_screen.session.entering():
            break


def test_aim_hold_and_launch_a_trial_that_is_recorded(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        assert "Trial 1 of 3" in panel(app) and "Aim (200, 80)" in panel(app)
        await pilot.press("right", "right", "shift+up")
        assert screen.session.aim == (208.0, 64.0)  # one step is an eighth of the radius; shift, four
        assert "Aim (208, 64)" in panel(app)
        await press_repeats(pilot, clock, 9)  # the last repeat at 900 ms
        screen.tick()
        field = app.query_one(ReachField)
        held = 900.0
        assert field.marks.ring_sd == pytest.approx(float(WORLD.sd((208.0, 64.0), held)))
        assert f"Holding {held:.0f} ms" in panel(app)
        earlier = field.marks.ring_sd
        clock.advance(PERIOD)
        await pilot.press("space")
        screen.tick()
        assert field.marks.ring_sd < earlier  # the ring shrinks while the key is held
        await let_go(pilot, clock)
        assert "Landed" in panel(app) and "Trial 2 of 3" in panel(app)
        assert field.marks.ring_sd is None and field.marks.endpoint is not None

    run(app, body)
    (step,) = read_reach_recording(app.first_screen.session.recorder.paths[0]).steps
    assert step.aim == (208.0, 64.0) and step.hold_exact is False
    assert step.duration_ms == pytest.approx(950 + PERIOD * 1000 / 2)


def test_a_tap_is_refused_in_words_and_not_recorded(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await pilot.press("space")
        await let_go(pilot, clock)
        assert "Too quick: hold longer (at least 150 ms)" in panel(app)
        assert "Trial 1 of 3" in panel(app)

    run(app, body)
    assert app.first_screen.session.recorder.paths == [] and not (tmp_path / "rec").exists()


def test_kitty_releases_time_the_reach_exactly(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)
    parser = KittyParser()

    async def feed(pilot: Pilot, data: str) -> None:
        for message in parser.feed(data):
            app.post_message(message)
        await pilot.pause()

    async def body(pilot: Pilot) -> None:
        await feed(pilot, "\x1b[32;1:1u")  # space down
        clock.advance(0.3)
        await feed(pilot, "\x1b[32;1:2u")  # a repeat
        clock.advance(0.337)
        await feed(pilot, "\x1b[32;1:3u")  # space up, 637 ms after it went down
        assert "Landed" in panel(app)

    run(app, body)
    (step,) = read_reach_recording(app.first_screen.session.recorder.paths[0]).steps
    assert step.hold_exact is True and step.duration_ms == pytest.approx(637)


def test_a_block_ends_and_takes_no_more_reaches(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path, trials=1)

    async def body(pilot: Pilot) -> None:
        await press_repeats(pilot, clock, 4)
        await let_go(pilot, clock)
        assert "Block done." in panel(app) and "1 trial · score" in panel(app) and "Landed" in panel(app)
        await press_repeats(pilot, clock, 4)
        await let_go(pilot, clock)
        await pilot.press("left")
        assert app.first_screen.session.aim == (200.0, 80.0)

    run(app, body)
    assert len(read_reach_recording(app.first_screen.session.recorder.paths[0]).steps) == 1


def test_a_window_too_small_cancels_the_reach_being_timed(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        await press_repeats(pilot, clock, 4)
        await pilot.resize_terminal(60, 20)
        await pilot.pause()
        shown = str(app.query_one("#too-small", Static).render())
        assert "needs 74x20" in shown and "reach being timed was cancelled" in shown
        await let_go(pilot, clock)
        await pilot.resize_terminal(100, 35)
        await pilot.pause()
        assert "Reach cancelled (window too small)" in panel(app)

    run(app, body)
    assert app.first_screen.session.recorder.paths == []
