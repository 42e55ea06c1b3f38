"""The fit view's key bar fits its terminal down to the view's minimum size, and `q quit` always shows."""

from __future__ import annotations

import asyncio
import io
from pathlib import Path

import pytest
from rich.console import Console

from careful_tui.app import make_fit_app
from careful_tui.cli import build_parser
from careful_tui.commands.fit import fit_from_args
from careful_tui.screens.fit import board_width
from careful_tui.widgets import KeyBar

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"
MINIMUM = (board_width(6, 0) + 4, 12)  # the view's smallest size for paper's 6 columns: 48x12


def bar_at(size: tuple[int, int]) -> tuple[str, bool]:
    """The key bar's text as the fit view shows it in a `size` terminal, and whether the view said too small."""
    args = build_parser().parse_args(["fit", str(SAMPLE)])
    app = make_fit_app(args, *fit_from_args(args, err=Console(file=io.StringIO())), show_times=False)
    seen = {}

    async def go() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            seen["bar"] = app.screen.query_one(KeyBar).render().plain.rstrip()
            seen["too_small"] = app.screen.has_class("-too-small")

    asyncio.run(go())
    return seen["bar"], seen["too_small"]


@pytest.mark.parametrize(("size", "chips"), [
    ((130, 30), ["a/l/o/m  auto/lp/loss/maxent", "i  intervals", "s  save SVG", "PgUp PgDn  scroll", "q  quit"]),
    ((100, 30), ["a/l/o/m  auto/lp/loss/maxent", "i  intervals", "s  save SVG", "q  quit"]),  # roomy
    ((60, 20), ["a/l/o/m auto/lp/loss/maxent", "i intervals", "s save SVG", "q quit"]),  # closed up
    (MINIMUM, ["a/l/o/m auto/lp/loss/maxent", "i intervals", "q quit"]),  # save SVG gives way
])
def test_the_fit_views_key_bar_fits_and_always_ends_with_quit(size, chips):
    bar, too_small = bar_at(size)
    assert not too_small
    assert len(bar) <= size[0] and bar.endswith(chips[-1])
    assert [chip for chip in chips if chip in bar] == chips
    assert ("save SVG" in bar) == any("save SVG" in chip for chip in chips)
