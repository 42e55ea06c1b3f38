"""How the play screen looks mid-hold: gauge part-filled, arrow grown (an SVG snapshot).

Update the snapshot after an intended change with `pytest tests/tui --snapshot-update`.
"""

from __future__ import annotations

from pathlib import Path

from play_fixtures import FakeClock
from textual.pilot import Pilot

from careful_tui.app import make_play_app
from irl_core.worlds.world import load_world


def test_play_screen_mid_hold(snap_compare) -> None:
    clock = FakeClock(50.0)
    # A relative folder that is never created: nothing is played, so nothing is recorded.
    app = make_play_app(load_world("paper"), out=Path("never-created"), player="snapshot", seed=4, clock=clock)

    async def hold_right(pilot: Pilot) -> None:
        await pilot.press("right")
        clock.now += 0.5
        for _ in range(26):
            await pilot.press("right")
            clock.now += 0.033
        app.first_screen.tick()
        await pilot.pause()

    assert snap_compare(app, run_before=hold_right, terminal_size=(100, 35))
    assert app.first_screen.game.t == 0 and not Path("never-created").exists()
