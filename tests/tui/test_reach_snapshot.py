"""How the reach screen looks mid-hold: the field, the ring around the aim moved right of the target's centre,
the panel (an SVG snapshot). Update it after an intended change with `pytest tests/tui --snapshot-update`."""

from __future__ import annotations

from pathlib import Path

from play_fixtures import FakeClock
from textual.pilot import Pilot

from careful_tui.app import make_reach_app
from irl_core.worlds.reach import REACH_WORLDS


def test_reach_screen_mid_hold(snap_compare) -> None:
    clock = FakeClock(50.0)
    # A relative folder that is never created: nothing is launched, so nothing is recorded (and the title
    # names no file made at a time of day).
    app = make_reach_app(REACH_WORLDS["reach"], out=Path("never-created"), player="snapshot", seed=4, trials=20,
                         clock=clock, event_times=False)

    async def hold(pilot: Pilot, repeats: int) -> None:  # space pressed, then its autorepeats
        await pilot.press("space")
        clock.now += 0.5
        for _ in range(repeats):
            await pilot.press("space")
            clock.now += 0.033

    async def aim_and_hold(pilot: Pilot) -> None:
        await pilot.press(*["right"] * 4)
        await hold(pilot, 8)
        app.first_screen.tick()
        await pilot.pause()

    assert snap_compare(app, run_before=aim_and_hold, terminal_size=(100, 35))
    assert app.first_screen.session.steps == [] and not Path("never-created").exists()
