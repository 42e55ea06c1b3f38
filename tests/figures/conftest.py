"""Fixed figure inputs (hand-written numbers shaped like a fit's) and baseline comparison.

Baselines in `baseline/` were drawn with the matplotlib version pinned in pyproject.toml;
`CAREFUL_UPDATE_BASELINES=1 pytest tests/figures` redraws them (look at them before committing).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

BASELINES = Path(__file__).parent / "baseline"
# RMS difference (0-255) allowed: anti-aliasing noise passes, a changed value or colour does not.
TOLERANCE = 2.0


@pytest.fixture
def matches_baseline(tmp_path):
    """`matches_baseline(figure, name)`: save the figure as PNG and compare it with baseline/<name>.png.

    `may_update=False` for a figure that must differ from its baseline: never written over it.
    """
    from matplotlib.testing.compare import compare_images

    from careful_tui.render.figures.style import save_figure

    def check(figure, name: str, *, may_update: bool = True) -> None:
        actual = tmp_path / f"{name}.png"
        save_figure(figure, actual)
        expected = BASELINES / f"{name}.png"
        if may_update and os.environ.get("CAREFUL_UPDATE_BASELINES"):
            shutil.copyfile(actual, expected)
        assert expected.exists(), f"no baseline {expected}; run with CAREFUL_UPDATE_BASELINES=1 and look at it"
        problem = compare_images(str(expected), str(actual), tol=TOLERANCE)
        assert problem is None, problem

    return check


@pytest.fixture
def mud_world():
    from irl_core.worlds.world import BUILTIN_WORLDS

    return BUILTIN_WORLDS["mud"]


@pytest.fixture
def mud_fitted(mud_world):
    """(rows, cols) a fitted reward of `mud` as an lp fit gives it."""
    from careful_tui.render.figures.board import Board

    fitted = Board.for_world(mud_world).rewards(mud_world)
    fitted[1, 1:3] = [-23.9, -31.0]
    fitted[3, 1:6] = [-1000.0, -946.2, -957.0, -937.4, 104.6]
    return fitted
