"""Rewards on a grid: a symmetric-log diverging colour scale centred on 0, with a colour bar.

Symmetric-log so that -1000 (a cliff) and -30 (mud) both read: values within `linthresh`
of 0 are on a linear scale, beyond it each power of ten gets the same length of colour bar.
The colour map is ColorBrewer's RdBu (bad red, good blue, 0 white), one of ColorBrewer's
maps marked safe for colour-blind readers; its two ends differ in lightness as well as hue.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.colors import SymLogNorm
from matplotlib.figure import Figure
from matplotlib.image import AxesImage
from matplotlib.patches import Rectangle

from careful_tui.render.figures.board import GROUND, Board
from careful_tui.render.figures.style import INK, PANEL_WIDTH, QUIET, figure_style, new_figure, plain
from careful_tui.render.grid import format_value

REWARD_CMAP = "RdBu"
LINTHRESH = 10.0  # |R| below this is drawn on a linear scale: the action costs (1 per level) live here
COLOUR_BAR_WIDTH = 0.55  # inches, with its labels
TITLE_HEIGHT = 0.25  # inches
# Text in a cell: "−1000" must fit its width; below the smallest size cells get no text.
CELL_TEXT_SIZES = (4.5, 6.0)  # points, smallest and largest
FULL_CELL = 24.0  # points: cells at least this wide get full-size arrows and outlines


def reward_limit(*grids: np.ndarray, linthresh: float = LINTHRESH) -> float:
    """The colour scale's end: the largest finite |value|, rounded up to 1, 2 or 5 x 10^k.

    At least `linthresh`, so an all-zero grid still has a scale.
    """
    values = np.concatenate([np.asarray(g, dtype=float).ravel() for g in grids]) if grids else np.zeros(0)
    finite = np.abs(values[np.isfinite(values)])
    top = max(float(finite.max()) if finite.size else 0.0, linthresh)
    power = 10.0 ** math.floor(math.log10(top))
    for step in (1, 2, 5, 10):
        if top <= step * power * (1 + 1e-9):
            return step * power
    return 10 * power


def reward_norm(vmax: float, *, linthresh: float = LINTHRESH) -> SymLogNorm:
    """Symmetric-log normalisation from -vmax to vmax: 0 maps to the middle of the colour map."""
    return SymLogNorm(linthresh=linthresh, linscale=0.5, vmin=-vmax, vmax=vmax, base=10)


def symlog_ticks(vmax: float, *, linthresh: float = LINTHRESH, ends: bool = True) -> list[float]:
    """0, ±linthresh and every power of ten up to vmax, and (with `ends`) ±vmax itself.

    Without `ends` a horizontal axis keeps its labels apart: ±2000 would sit on ±1000's.
    """
    powers = [10.0**k for k in range(math.ceil(math.log10(linthresh)), 16) if 10.0**k <= vmax * (1 + 1e-9)]
    positive = sorted({*powers, vmax}) if ends else powers
    return [*(-p for p in reversed(positive)), 0.0, *positive]


def value_label(value: float) -> str:
    """A reward as a cell shows it: "−1000", "−31.5", "0", with a true minus sign (and no "−0.0")."""
    value = float(value)
    return "0" if abs(value) < 0.05 else format_value(value).replace("-", "\N{MINUS SIGN}")


def text_colour(rgba: Sequence[float] | np.ndarray) -> str:
    """Dark text on light colours, white on dark ones (by relative luminance)."""
    r, g, b = rgba[:3]
    return INK if 0.299 * r + 0.587 * g + 0.114 * b > 0.55 else "white"


def cell_width(grid_width: float, cols: int) -> float:
    """Points per cell when `cols` cells share `grid_width` inches."""
    return grid_width * 72.0 / max(cols, 1)


def cell_text_size(width: float) -> float | None:
    """The font size (points) for text in a cell `width` points wide; None if it would be too small.

    Five characters ("−1000") of DejaVu Sans take 3.4 times the font size, and the axes end up a
    little narrower than asked for once the layout is done: hence 3.8.
    """
    size = width / 3.8
    smallest, largest = CELL_TEXT_SIZES
    return None if size < smallest else min(size, largest)


def draw_board(ax: Axes, board: Board, *, width: float = FULL_CELL) -> None:
    """The frame every grid figure shares: cells in rows and columns, walls hatched, terminal cells outlined.

    `width`: points per cell; outlines thin out in smaller cells, and lines between cells go below 8 points.
    """
    scale = min(1.0, width / FULL_CELL)
    rows, cols = board.shape
    ax.set_xlim(-0.5, cols - 0.5)
    ax.set_ylim(rows - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    for r, c in zip(*np.nonzero(board.wall)):
        ax.add_patch(Rectangle((c - 0.5, r - 0.5), 1, 1, facecolor="#d9d9d9", edgecolor="#7a7a7a",
                               hatch="////", linewidth=0, zorder=2))
    for r, c in zip(*np.nonzero(board.terminal)):
        ax.add_patch(Rectangle((c - 0.44, r - 0.44), 0.88, 0.88, fill=False, edgecolor=INK,
                               linewidth=0.9 * scale, zorder=4))
    if width < 8:
        return
    # Thin white lines between cells.
    for x in range(1, cols):
        ax.axvline(x - 0.5, color="white", linewidth=0.6, zorder=3)
    for y in range(1, rows):
        ax.axhline(y - 0.5, color="white", linewidth=0.6, zorder=3)


def draw_reward(ax: Axes, values: np.ndarray, board: Board, *, norm: SymLogNorm, title: str | None = None,
                width: float = FULL_CELL, labels: dict[tuple[int, int], str] | None = None) -> AxesImage:
    """One reward grid on `ax`: colour by value, and symbol and value in each cell.

    Args:
        values: (rows, cols) R_S per cell; NaN where there is none (walls).
        width: points per cell: the symbol (other than ground) and value are written in each
            cell when they can be read at that size.
        labels: (row, col) -> the words for that cell's value instead of the number ("≤ -14.6": a reward
            bounded on one side, shown as its bound).
    """
    text_size = cell_text_size(width)
    shown = np.ma.masked_invalid(np.where(board.wall, np.nan, np.asarray(values, dtype=float)))
    cmap = colormaps[REWARD_CMAP].with_extremes(bad="#f0f0f0")
    image = ax.imshow(shown, cmap=cmap, norm=norm, interpolation="nearest", zorder=1)
    draw_board(ax, board, width=width)
    if title:
        ax.set_title(title, pad=3)
    if text_size is not None:
        for (r, c), value in np.ndenumerate(shown.filled(np.nan)):
            if board.wall[r, c]:
                continue
            colour = text_colour(image.to_rgba(value)) if np.isfinite(value) else INK
            symbol = board.symbols[r, c]
            if symbol == GROUND and value == 0:
                colour = QUIET  # the neutral ground: present, but not competing with the rewards
            said = (labels or {}).get((r, c)) or value_label(value)
            text = said if symbol == GROUND else f"{plain(str(symbol))}\n{said}"
            ax.text(c, r, text, ha="center", va="center", color=colour, fontsize=text_size, linespacing=1.1, zorder=5)
    return image


def add_colour_bar(figure: Figure, image: AxesImage, axes: Sequence[Axes], *, vmax: float,
                   linthresh: float = LINTHRESH, label: str = "state reward") -> None:
    bar = figure.colorbar(image, ax=list(axes), fraction=0.08, pad=0.03, aspect=14)
    bar.set_ticks(symlog_ticks(vmax, linthresh=linthresh))
    bar.set_ticklabels([value_label(t) for t in symlog_ticks(vmax, linthresh=linthresh)])
    bar.ax.minorticks_off()
    bar.set_label(label, labelpad=2)
    bar.outline.set_linewidth(0.5)


def reward_figure(panels: Sequence[tuple[str, np.ndarray]], board: Board, *, vmax: float | None = None,
                  linthresh: float = LINTHRESH, panel_width: float = PANEL_WIDTH) -> Figure:
    """Reward grids side by side on one colour scale, with one colour bar.

    Args:
        panels: (title, values (rows, cols)) per grid, e.g. [("fitted", R), ("true", R_true)].
        vmax: the scale's end (default: `reward_limit` of every panel).
        panel_width: inches per grid (the colour bar adds `COLOUR_BAR_WIDTH`).
    """
    rows, cols = board.shape
    vmax = reward_limit(*(values for _, values in panels), linthresh=linthresh) if vmax is None else vmax
    grid_width = panel_width - COLOUR_BAR_WIDTH if len(panels) == 1 else panel_width * 0.85
    with figure_style():
        figure = new_figure(grid_width * len(panels) + COLOUR_BAR_WIDTH, grid_width * rows / cols + TITLE_HEIGHT)
        axes = figure.subplots(1, len(panels), squeeze=False)[0]

        norm = reward_norm(vmax, linthresh=linthresh)
        image = None
        for ax, (title, values) in zip(axes, panels):
            image = draw_reward(ax, values, board, norm=norm, title=title,
                                width=cell_width(grid_width, cols))
        assert image is not None, "a reward figure has at least one panel"
        add_colour_bar(figure, image, axes, vmax=vmax, linthresh=linthresh)
    return figure
