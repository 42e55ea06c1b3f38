"""A reach fit as one figure: what `careful fit REACH.jsonl --figure PATH` writes (docs/reach.md).

First row: the field around its circles, with every recorded endpoint (a dot), every aim (a cross), and
the expected-gain maximiser's aim for the fitted points (filled diamond) and for the world's own points
(open diamond); beside it each reach's duration against the distance of its aim from the penalty's rim
(the circles of the worst symbol), with the two optimal choices marked the same way. Second row: each
symbol's interval, on the symmetric-log axis of the grid fits' interval plots; a symbol bounded on one side
only is drawn as its bound, never with a point.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from careful_tui.render.figures.intervals import (
    FRAME_HEIGHT,
    LEGEND_HEIGHT,
    ROW_HEIGHT,
    IntervalRow,
    draw_intervals,
    interval_legend,
    symbol_colour,
    worst_first,
)
from careful_tui.render.figures.style import INK, PAGE_WIDTH, QUIET, figure_style, new_figure, plain
from careful_tui.render.reach_fit import (
    Optima,
    has_point,
    optima,
    penalty_distance,
    penalty_symbols,
    reach_fit_title,
    shown_points,
    view_box,
)
from irl_core.reach.fit import RMAX, ReachFit
from irl_core.recordings.reach_reader import Reaches
from irl_core.support.plural import plural

FIELD_HEIGHT = 2.6  # inches: the first row
# The optimum for the fitted points a small filled diamond, for the world's points a larger open one drawn
# over it: where the two coincide both still show.
FITTED_STYLE: dict[str, Any] = {"marker": "D", "markersize": 3.5, "markerfacecolor": "#D55E00", "markeredgecolor": "#D55E00",
                "markeredgewidth": 0.8, "zorder": 5}
TRUE_STYLE: dict[str, Any] = {"marker": "D", "markersize": 6.5, "markerfacecolor": "none", "markeredgecolor": INK,
              "markeredgewidth": 1.0, "zorder": 6}


def draw_field(ax: Axes, fit: ReachFit, reaches: Reaches, best: Optima) -> None:
    """The circles, the endpoints and aims, and both optimal aims, in field units (y down, as the world's)."""
    world = fit.world
    symbols = list(world.symbols)
    for region in world.regions:
        colour = symbol_colour(region.symbol, symbols)
        ax.add_patch(Circle(region.centre, region.radius, facecolor=colour, alpha=0.18, edgecolor=colour,
                            linewidth=0.8, zorder=1))
    for symbol in symbols:  # one label a symbol, at its first circle's top
        region = next(r for r in world.regions if r.symbol == symbol)
        ax.text(region.centre[0], region.centre[1] - region.radius - 2, f"{plain(symbol)} {shown_points(fit, symbol)}",
                ha="center", va="bottom", fontsize=6, color=symbol_colour(symbol, symbols))
    low, high = view_box(world)
    ax.scatter(reaches.endpoints[:, 0], reaches.endpoints[:, 1], s=3, color=QUIET, linewidths=0, zorder=2,
               label="endpoint")
    ax.scatter(reaches.aims[:, 0], reaches.aims[:, 1], s=9, marker="x", color=INK, linewidths=0.5, alpha=0.6,
               zorder=3, label="aim")
    for (aim, _), name in best.shown:
        ax.plot([aim[0]], [aim[1]], linestyle="", **(FITTED_STYLE if name == "fitted" else TRUE_STYLE))
    ax.set_xlim(low[0], high[0])
    ax.set_ylim(high[1], low[1])  # y runs down the field, as in the world file
    ax.set_aspect("equal")
    outside = int(np.sum(np.any((reaches.endpoints < low) | (reaches.endpoints > high), axis=1)))
    notes = [f"x (field units); the start is at y = {world.start[1]:g}"]
    if outside:
        notes.append(f"{plural(outside, 'endpoint')} outside this view")
    if best.fitted is None:
        notes.append("no best aim for the fitted points: some may be any value")
    ax.set_xlabel("\n".join(notes), labelpad=2)
    ax.set_ylabel("y (down)", labelpad=2)
    ax.set_title("endpoints and aims", pad=3)
    ax.tick_params(length=2)


def draw_durations(ax: Axes, fit: ReachFit, reaches: Reaches, best: Optima) -> None:
    """Each reach's duration against its aim's distance from the penalty's rim, and both optimal choices."""
    world = fit.world
    distance = penalty_distance(world, reaches.aims)
    ax.scatter(distance, reaches.durations, s=6, color=INK, alpha=0.5, linewidths=0, zorder=2)
    for (aim, duration), name in best.shown:
        ax.plot(penalty_distance(world, aim[None, :]), [duration], linestyle="",
                **(FITTED_STYLE if name == "fitted" else TRUE_STYLE))
    ax.axvline(0, color="#bbbbbb", linewidth=0.5, zorder=1)  # the rim
    shown = np.r_[distance, penalty_distance(world, np.array([aim for (aim, _), _ in best.shown])), 0.0]
    margin = max(float(np.ptp(shown)) * 0.08, 1.0)
    ax.set_xlim(float(shown.min()) - margin, float(shown.max()) + margin)
    ax.set_ylim(world.min_ms * 0.95, world.max_ms * 1.05)
    names = ", ".join(plain(symbol) for symbol in penalty_symbols(world))
    ax.set_xlabel(f"aim's distance from the rim of {names}", labelpad=2)
    ax.set_ylabel("duration (ms)", labelpad=2)
    ax.set_title("duration by distance to the penalty", pad=3)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)


def interval_rows(fit: ReachFit) -> list[IntervalRow]:
    """A row per fitted symbol (a known one has no interval to show); one bounded on one side has no estimate."""
    rows = []
    for symbol, (low, high) in fit.interval.items():
        if low == high:
            continue  # held at a known value
        estimate = fit.reward[symbol] if has_point(fit, symbol) else float("nan")
        rows.append(IntervalRow(plain(symbol), symbol, low, high, estimate, fit.world.points[symbol]))
    return rows


def reach_fit_figure(fit: ReachFit, reaches: Reaches) -> Figure:
    """The field with the reaches and the optima, the durations by distance, and the intervals."""
    rows = interval_rows(fit)
    heights = [FIELD_HEIGHT] + ([FRAME_HEIGHT + LEGEND_HEIGHT + ROW_HEIGHT * len(rows)] if rows else [])
    best = optima(fit)
    with figure_style():
        figure = new_figure(PAGE_WIDTH, sum(heights))
        top, *bottom = figure.subfigures(len(heights), 1, height_ratios=heights, squeeze=False)[:, 0]
        ax_field, ax_durations = top.subplots(1, 2, gridspec_kw={"width_ratios": [1.1, 1]})
        draw_field(ax_field, fit, reaches, best)
        ax_field.set_label("field")
        draw_durations(ax_durations, fit, reaches, best)
        ax_durations.set_label("durations")
        handles = [Line2D([], [], linestyle="", marker="o", markersize=2, color=QUIET, label="endpoint"),
                   Line2D([], [], linestyle="", marker="x", markersize=3, color=INK, label="aim"),
                   Line2D([], [], linestyle="", label="best choice for the fitted points",
                          **{**FITTED_STYLE, "zorder": None}),
                   Line2D([], [], linestyle="", label="for the world's points", **{**TRUE_STYLE, "zorder": None})]
        top.legend(handles=handles, loc="outside lower center", ncol=4, handlelength=1.0, columnspacing=0.9,
                   handletextpad=0.3)
        top.suptitle(plain(reach_fit_title(fit), limit=120), fontsize=7)
        if bottom:
            ax_int = bottom[0].subplots()
            draw_intervals(ax_int, worst_first(rows), rmax=RMAX, title=_interval_title(fit))
            ax_int.set_label("intervals")
            legend = interval_legend(rows, kind=fit.interval_kind, confidence=fit.confidence
                                     if fit.interval_kind == "confidence" else None, rmax=RMAX)
            bottom[0].legend(handles=legend, loc="outside lower center", ncol=len(legend), handlelength=1.2,
                             columnspacing=0.9, handletextpad=0.3)
    return figure


def _interval_title(fit: ReachFit) -> str:
    if fit.interval_kind == "confidence":
        return f"each symbol's points: {fit.confidence:.0%} confidence intervals (Laplace)"
    return "each symbol's points: identified by the choices (every value they allow)"
