"""`s` in the fit view saves the whole fit, not the part of the view scrolled into sight.

In a 100x24 terminal the view shows its boards; the policy and the verdict are below, out of
sight. The saved SVG had only what the screen showed (issue 31).
"""

from __future__ import annotations

import asyncio
from pathlib import Path

from careful_tui.app import CarefulApp
from careful_tui.screens.fit import FitScreen
from irl_core.irl import FitOptions
from irl_core.recordings.demonstrations import Demonstrations

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"


def test_s_saves_what_is_below_the_screen_too(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    screen = FitScreen(Demonstrations.read([SAMPLE]), FitOptions(), sources=[SAMPLE])
    app = CarefulApp(screen)

    async def main() -> str:
        async with app.run_test(size=(100, 24)) as pilot:
            for _ in range(200):
                await pilot.pause(0.05)
                if screen.result is not None:
                    break
            await pilot.pause()
            shown = app.export_screenshot()
            await pilot.press("s")
            await pilot.pause()
            return shown

    shown = asyncio.run(main())
    (saved,) = screen.saved
    def text(svg: str) -> str:
        return svg.replace("&#160;", " ")

    below = "×5"  # the demonstrated policy's count in the cell above the goal, below the screen's edge
    assert below not in text(shown)
    assert below in text(saved.read_text())
    assert "status: " in text(saved.read_text())  # the printout's last line
