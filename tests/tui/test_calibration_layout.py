"""The calibration box reads as written in a common terminal and fits in play's smallest (Pilot)."""

from __future__ import annotations

import asyncio
from pathlib import Path

from play_fixtures import FakeClock, corner_world
from test_calibration_stall import calibrating_app, stamped_key
from test_play_redraw import visible

from careful_tui.screens.calibration import CalibrationScreen
from careful_tui.screens.play import minimum_size


def holding_box(tmp_path: Path, size: tuple[int, int]) -> tuple[list[str], bool]:
    """The calibration text's lines a second into a hold, and whether its box lies on the screen."""
    clock = FakeClock()
    app = calibrating_app(tmp_path, clock, event_times=True)
    seen: dict[str, object] = {}

    async def main() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            screen = app.screen
            assert isinstance(screen, CalibrationScreen)
            start = clock.now
            for at in (start, *(start + 0.5 + k * 0.033 for k in range(16))):
                clock.now = at
                app.post_message(stamped_key("up", at))
                await pilot.pause()
            await pilot.pause()
            seen["lines"] = [line.strip() for line in visible(screen.query_one("#calibration-text")).splitlines()]
            seen["fits"] = screen.region.contains_region(screen.query_one("#calibration-box").region)

    asyncio.run(main())
    return seen["lines"], seen["fits"]


def assert_each_paragraph_is_one_line(lines: list[str]) -> None:
    assert lines[0] == "Hold any arrow key down for 2 seconds, then let go."
    assert lines[2].endswith("1.0 s   16 repeats")
    assert lines[4] == "This measures your key repeat; levels count from it."
    assert lines[6] == "esc  cancel"
    assert lines[1] == lines[3] == lines[5] == "", lines


def test_each_paragraph_of_the_hold_prompt_is_one_line_at_80_columns(tmp_path: Path) -> None:
    lines, fits = holding_box(tmp_path, (80, 24))
    assert fits
    assert_each_paragraph_is_one_line(lines)


def test_the_box_fits_in_the_smallest_terminal_play_runs_in(tmp_path: Path) -> None:
    # Its paragraphs are not broken either (the note once left "it." alone on a line here).
    lines, fits = holding_box(tmp_path, minimum_size(corner_world()))
    assert fits, "the box runs off the screen"
    assert_each_paragraph_is_one_line(lines)
