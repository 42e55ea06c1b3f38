"""A move cancelled because the window got too small stays cancelled while its key is held
(Pilot, fake clock): on a legacy terminal the key's autorepeats keep coming, and after the window
grows again they must not start a move the player never pressed for."""

from __future__ import annotations

import asyncio
from pathlib import Path

from play_fixtures import FakeClock, corner_world
from textual.pilot import Pilot

from careful_tui.app import CarefulApp, make_play_app
from careful_tui.screens.play import PlayScreen
from irl_core.recordings.demonstrations import read_recording

SIZE, SMALL = (100, 35), (40, 12)
PERIOD = 0.033


def directions(app: CarefulApp) -> list[str]:
    screen = app.first_screen
    assert isinstance(screen, PlayScreen)
    return [step.direction for path in screen.recorder.paths for step in read_recording(path).steps]


async def autorepeat(pilot: Pilot, clock: FakeClock, key: str, seconds: float) -> None:
    """The terminal autorepeats `key` (every 33 ms) for `seconds`, the screen's timer running between."""
    for _ in range(round(seconds / PERIOD)):
        clock.advance(PERIOD)
        await pilot.press(key)
        pilot.app.first_screen.tick()


def test_the_held_key_of_a_move_cancelled_by_a_small_window_makes_no_move_when_it_grows(tmp_path: Path) -> None:
    clock = FakeClock()
    app = make_play_app(corner_world(), out=tmp_path / "rec", player="tester", seed=1, clock=clock)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        await pilot.press("right")
        clock.advance(0.5)
        await pilot.press("right")
        await autorepeat(pilot, clock, "right", 0.3)
        assert screen.input.current() is not None and screen.input.current().level == 3
        await pilot.resize_terminal(*SMALL)
        await pilot.pause()
        assert screen.too_small and screen.input.current() is None
        await autorepeat(pilot, clock, "right", 1.0)  # still held while the window is small
        await pilot.resize_terminal(*SIZE)
        await pilot.pause()
        assert not screen.too_small
        await autorepeat(pilot, clock, "right", 1.0)  # ... and after it grew
        assert screen.input.current() is None, "the held key started a new hold"
        clock.advance(1.0)  # let go
        screen.tick()
        await pilot.pause()
        assert screen.game.t == 0
        # A fresh press is a move again.
        await pilot.press("down")
        clock.advance(1.0)
        screen.tick()
        await pilot.pause()
        assert screen.game.t == 1

    async def main() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(main())
    assert directions(app) == ["down"]
