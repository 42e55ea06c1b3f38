"""Small multiples: one small panel per participant, on shared scales, for a study's report.

- `reward_multiples`: a fitted reward grid per panel (`heatmap.draw_reward`), one colour scale
  and one colour bar for all, so the same colour is the same reward in every panel.
- `carefulness_multiples`: mean carefulness against distance to danger per panel
  (`carefulness.draw_carefulness`), on shared axes, with a reference line (everyone pooled)
  drawn faintly in each panel so that each participant reads against the group; on a time world
  the geometric mean hold instead (`carefulness.draw_holds_by_distance`), on a log scale.
Panels fill rows of `columns` from the top left; a page wide.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence

import matplotlib as mpl
import numpy as np
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import text_to_path

from careful_tui.render.figures.board import Board
from careful_tui.render.figures.carefulness import (
    CarefulnessByDistance,
    HoldsByDistance,
    draw_carefulness,
    draw_holds_by_distance,
)
from careful_tui.render.figures.heatmap import (
    COLOUR_BAR_WIDTH,
    TITLE_HEIGHT,
    add_colour_bar,
    cell_width,
    draw_reward,
    reward_limit,
    reward_norm,
)
from careful_tui.render.figures.style import OKABE_ITO, PAGE_WIDTH, QUIET, figure_style, new_figure

SUPTITLE_HEIGHT = 0.3  # inches
CAREFULNESS_PANEL_HEIGHT = 0.95  # inches per row of carefulness panels
AXIS_LABEL_HEIGHT = 0.35  # inches for the shared axis labels


def panel_title(label: str, width: float) -> str:
    """`label` in lines that fit a panel `width` inches wide: a long participant id would run into its neighbours'.

    Call inside `figure_style` (the title's font is measured).
    """
    font = FontProperties(size=mpl.rcParams["axes.titlesize"])
    measured = text_to_path.get_text_width_height_descent(label, font, ismath=False)[0] / 72  # inches
    if measured <= width:
        return label
    return textwrap.fill(label, max(8, int(len(label) * width / measured)))


def _grid_shape(panels: int, columns: int) -> tuple[int, int]:
    columns = max(1, min(columns, panels))
    return math.ceil(panels / columns), columns


def reward_multiples(panels: Sequence[tuple[str, np.ndarray]], board: Board, *, vmax: float | None = None,
                     columns: int = 6, title: str | None = None) -> Figure:
    """Reward grids in rows of `columns`, one colour scale, one colour bar.

    Args:
        panels: (title, values (rows, cols)) per grid, e.g. [("true", R), ("p01", R_1), ...].
        vmax: the colour scale's end (default: `reward_limit` of every panel).
    """
    n_rows, n_cols = _grid_shape(len(panels), columns)
    rows, cols = board.shape
    vmax = reward_limit(*(values for _, values in panels)) if vmax is None else vmax
    grid_width = (PAGE_WIDTH - COLOUR_BAR_WIDTH) / n_cols * 0.94
    height = n_rows * (grid_width * rows / cols + TITLE_HEIGHT) + (SUPTITLE_HEIGHT if title else 0.05)
    with figure_style():
        figure = new_figure(PAGE_WIDTH, height)
        axes = figure.subplots(n_rows, n_cols, squeeze=False)
        norm = reward_norm(vmax)
        image = None
        for ax, (label, values) in zip(axes.ravel(), panels):
            image = draw_reward(ax, values, board, norm=norm, title=panel_title(label, grid_width),
                                width=cell_width(grid_width, cols))
        for ax in axes.ravel()[len(panels):]:
            ax.set_visible(False)
        assert image is not None, "small multiples have at least one panel"
        add_colour_bar(figure, image, axes.ravel().tolist(), vmax=vmax)
        if title:
            figure.suptitle(title, fontsize=7, wrap=True)
    return figure


def carefulness_multiples(panels: Sequence[tuple[str, CarefulnessByDistance | HoldsByDistance]], *, levels: int,
                          reference: tuple[str, CarefulnessByDistance | HoldsByDistance] | None = None,
                          columns: int = 6, title: str | None = None) -> Figure:
    """Mean carefulness (or, for `HoldsByDistance`, the geometric mean hold) against distance to danger, a panel
    per participant on shared axes.

    Args:
        panels: (title, data) per panel, all of one kind.
        levels: L, the top of every y axis (levels only).
        reference: (label, data) drawn faintly in every panel (e.g. everyone pooled).
    """
    holds = isinstance(panels[0][1], HoldsByDistance)
    n_rows, n_cols = _grid_shape(len(panels), columns)
    height = n_rows * CAREFULNESS_PANEL_HEIGHT + AXIS_LABEL_HEIGHT + SUPTITLE_HEIGHT * 2
    with figure_style():
        figure = new_figure(PAGE_WIDTH, height)
        axes = figure.subplots(n_rows, n_cols, squeeze=False, sharex=True, sharey=True)
        for ax, (label, data) in zip(axes.ravel(), panels):
            title_fitted = panel_title(label, PAGE_WIDTH / n_cols * 0.85)  # less the axis' labels
            if reference is not None:
                line = reference[1]
                ax.plot(line.distance, line.geometric_mean if isinstance(line, HoldsByDistance) else line.mean,
                        color=QUIET, linewidth=1.6, alpha=0.6, zorder=1)
            if isinstance(data, HoldsByDistance):
                draw_holds_by_distance(ax, data, colour=OKABE_ITO[1], title=title_fitted)
            else:
                draw_carefulness(ax, [(label, data)], levels=levels, title=title_fitted)
                ax.get_legend().remove()
            ax.set_xlabel("")
            ax.set_ylabel("")
        for ax in axes.ravel()[len(panels):]:
            ax.set_visible(False)
        figure.supxlabel("steps to the nearest terminal cell", fontsize=7)
        figure.supylabel("hold (ms), geometric mean" if holds else "mean carefulness level", fontsize=7)
        # The key goes under the title as words: a legend box collides with the title or the axis label.
        key = ("blue: the participant's geometric mean hold ± 95% confidence interval (1.96 standard errors of the "
               "mean log hold)" if holds else
               "blue: the participant's mean carefulness ± 95% confidence interval (1.96 standard errors)")
        if reference is not None:
            key += f"; grey: {reference[0]}"
        figure.suptitle(f"{title}\n{key}" if title else key, fontsize=7, wrap=True)
    return figure
