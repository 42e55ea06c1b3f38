"""Play's feel for participants, on the play screen (Pilot, fake clock): a calibrated profile
shortens the wait before a tap is a move, a second tap of the same arrow during that wait is a
second move in hold mode (and a level in tap mode), and a shrink mid-move cancels the move."""

from __future__ import annotations

from pathlib import Path

import pytest
from play_fixtures import FakeClock
from test_play_app import new_app, run
from textual.pilot import Pilot

from careful_tui.app import CarefulApp
from irl_core.play.calibration import Calibration
from irl_core.play.hold import HoldProfile
from irl_core.recordings.demonstrations import read_recording

SMALL = (40, 12)


def calibrated(delay_s: float, period_s: float) -> HoldProfile:
    """What the calibration screen hands play after a 2 s hold on this keyboard."""
    calibration = Calibration(HoldProfile(levels=14))
    for k in range(int(1.6 / period_s)):
        calibration.feed("up", 0.0 if k == 0 else delay_s + (k - 1) * period_s)
    return calibration.result()


async def tick_at(pilot: Pilot, clock: FakeClock, at: float, started: float) -> None:
    """Move the clock to `at` seconds after `started` and let the screen's timer run."""
    clock.now = started + at
    pilot.app.first_screen.tick()
    await pilot.pause()


def steps(app: CarefulApp) -> list[tuple[str, int]]:
    """(direction, level) of every step in the app's files."""
    paths = app.first_screen.recorder.paths
    return [(s.direction, s.carefulness) for path in paths for s in read_recording(path).steps]


@pytest.mark.parametrize(("profile", "wait_s"), [(None, 0.7), (calibrated(0.3, 0.03), 0.4)],
                         ids=["uncalibrated", "calibrated"])
def test_a_tap_is_a_move_after_the_profiles_wait(tmp_path: Path, profile: HoldProfile | None,
                                                 wait_s: float) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        if profile is not None:
            screen.use_profile(profile)
        started = clock.now
        await pilot.press("right")
        await tick_at(pilot, clock, wait_s - 0.01, started)
        assert screen.game.t == 0, "committed before the wait was over"
        await tick_at(pilot, clock, wait_s, started)
        assert screen.game.t == 1

    run(app, body)
    assert steps(app) == [("right", 1)]
    header = read_recording(app.first_screen.recorder.paths[0]).header
    assert header.input["tap_wait_ms"] == pytest.approx(wait_s * 1000)


def test_hold_mode_a_second_tap_during_the_wait_is_a_second_move(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        screen.use_profile(calibrated(0.5, 0.033))  # second presses before 400 ms
        started = clock.now
        await pilot.press("right")
        clock.now = started + 0.25
        await pilot.press("right")
        # The first tap is committed at once, at level 1; the second waits for its own end.
        assert screen.game.t == 1
        await tick_at(pilot, clock, 0.25 + 0.59, started)
        assert screen.game.t == 1
        await tick_at(pilot, clock, 0.25 + 0.6, started)
        assert screen.game.t == 2

    run(app, body)
    assert steps(app) == [("right", 1), ("right", 1)]


def test_tap_mode_a_second_tap_is_a_level(tmp_path: Path) -> None:
    """In tap mode, as README "Playing" says, tapping an arrow k times quickly is one move at level k."""
    app, clock = new_app(tmp_path, input_mode="tap")

    async def body(pilot: Pilot) -> None:
        started = clock.now
        await pilot.press("right")
        clock.now = started + 0.1
        await pilot.press("right")
        await tick_at(pilot, clock, 0.1 + 0.4, started)
        assert app.first_screen.game.t == 1

    run(app, body)
    assert steps(app) == [("right", 2)]


@pytest.mark.parametrize(("mode", "keys"), [("hold", ["right"]), ("tap", ["right", "right"]), ("digits", ["5"])])
def test_shrinking_mid_move_cancels_it_and_says_so(tmp_path: Path, mode: str, keys: list[str]) -> None:
    app, clock = new_app(tmp_path, input_mode=mode)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        await pilot.press(*keys)
        assert screen.input.current() is not None
        await pilot.resize_terminal(*SMALL)
        await pilot.pause()
        assert screen.has_class("-too-small") and screen.input.current() is None
        assert "The move being entered was cancelled." in str(app.query_one("#too-small").render())
        clock.advance(2.0)
        screen.tick()
        await pilot.resize_terminal(100, 35)
        await pilot.pause()
        assert screen.game.t == 0
        assert "Move cancelled (window too small)." in str(app.query_one("#status").render())
        # Play goes on: the next move is made as usual.
        await pilot.press("down")
        clock.advance(2.0)
        screen.tick()
        await pilot.pause()
        assert screen.game.t == 1

    run(app, body)
    assert steps(app) == [("down", 1)]


def test_a_resize_that_still_fits_keeps_the_hold(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        started = clock.now
        await pilot.press("right")
        for k in range(10):
            clock.now = started + 0.5 + k * 0.033
            await pilot.press("right")
        await pilot.resize_terminal(90, 30)
        await pilot.pause()
        assert screen.input.current() is not None
        await tick_at(pilot, clock, 2.0, started)
        assert screen.game.t == 1

    run(app, body)
    [(direction, level)] = steps(app)
    assert direction == "right" and level == HoldProfile().level_for(0.5 * 1000 + 9 * 33 + 33 / 2)
