"""Reward intervals: one row per unknown on a symmetric-log axis.

The interval is a bar, the estimate a dot, the truth a tick. Rows of one symbol sit together
and symbols are ordered from worst to best, so the cliff's rows are next to the mud's and
whether their bars overlap is seen at a glance. The legend names the kind of interval: the
set of rewards the demonstrations identify (lp), or a confidence interval for sampling noise.
An end at ±rmax is not a bound from the data, only the fit's box: a triangle marks it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from careful_tui.render.figures.heatmap import LINTHRESH, reward_limit, symlog_ticks, value_label
from careful_tui.render.figures.style import INK, OKABE_ITO, PANEL_WIDTH, figure_style, new_figure
from irl_core.irl import at_bound as core_at_bound

INTERVAL_KINDS = ("identified", "confidence")
SYMBOL_COLOURS = {"C": OKABE_ITO[0], "G": OKABE_ITO[1], "U": OKABE_ITO[2]}
ROW_HEIGHT = 0.17  # inches per row
FRAME_HEIGHT = 0.95  # inches for title, axis and ticks
LEGEND_HEIGHT = 0.3  # inches for the legend's title and row
OPEN_END = 1.35  # an end at ±rmax is marked at ±rmax * OPEN_END, in the axis' margin


@dataclass(frozen=True)
class IntervalRow:
    """One unknown: its name, interval, estimate (NaN: none, the reward bounded on one side only) and true value
    (NaN when unknown)."""

    label: str
    symbol: str
    low: float
    high: float
    estimate: float
    truth: float = float("nan")


def kind_label(kind: str, confidence: float | None = None) -> str:
    """What the bars are, for the legend: "identified by the demonstrations" or "95% confidence interval"."""
    if kind == "identified":
        return "identified by the demonstrations"
    if kind == "confidence":
        if confidence is None:
            raise ValueError("a confidence interval needs its confidence level")
        return f"{confidence:.0%} confidence interval"
    raise ValueError(f"interval kind must be one of {INTERVAL_KINDS}, not {kind!r}")


def at_bound(value: float, rmax: float | None) -> bool:
    """Whether an interval's end sits on the ±rmax box (the demonstrations do not bound it there).

    With `rmax` None (the bound is not known) no end is.
    """
    return rmax is not None and bool(core_at_bound(value, rmax))


def axis_limit(rows: Sequence[IntervalRow], rmax: float | None, *, linthresh: float = LINTHRESH) -> float:
    """Where the axis ends: at ±rmax, or without a known bound just beyond every value drawn."""
    if rmax is not None:
        return rmax
    values = np.array([v for row in rows for v in (row.low, row.high, row.estimate, row.truth) if np.isfinite(v)])
    return reward_limit(values, linthresh=linthresh)


def symbol_colour(symbol: str, order: Sequence[str]) -> str:
    """The cliff vermillion, the goal blue, mud purple; other symbols take the palette's next colours."""
    if symbol in SYMBOL_COLOURS:
        return SYMBOL_COLOURS[symbol]
    others = [s for s in order if s not in SYMBOL_COLOURS]
    return OKABE_ITO[3 + others.index(symbol) % (len(OKABE_ITO) - 3)]


def worst_first(rows: Sequence[IntervalRow]) -> list[IntervalRow]:
    """Rows grouped by symbol, the symbol with the lowest interval top first, then by label."""
    top: dict[str, float] = {}
    for row in rows:
        top[row.symbol] = max(top.get(row.symbol, -np.inf), row.high)
    return sorted(rows, key=lambda row: (top[row.symbol], row.symbol, row.label))


def draw_intervals(ax: Axes, rows: Sequence[IntervalRow], *, rmax: float | None, linthresh: float = LINTHRESH,
                   title: str | None = None) -> None:
    """The rows (top to bottom in the order given) on a symmetric-log axis from -rmax to rmax.

    `rmax`: the fit's bound |R_S| <= rmax, or None when it is not known: then the axis ends
    just beyond the values drawn and no end is marked as unbounded.
    """
    limit = axis_limit(rows, rmax, linthresh=linthresh)
    symbols = list(dict.fromkeys(row.symbol for row in rows))
    for y, row in enumerate(rows):
        colour = symbol_colour(row.symbol, symbols)
        ax.barh(y, row.high - row.low, left=row.low, height=0.55, color=colour, alpha=0.35,
                edgecolor=colour, linewidth=0.8, zorder=2)
        # An end on the ±rmax box gets a triangle in the margin beyond it, pointing away.
        for end, marker, sign in ((row.low, "<", -1), (row.high, ">", 1)):
            if at_bound(end, rmax) and np.sign(end) == sign:
                ax.plot([sign * limit * OPEN_END], [y], marker=marker, markersize=4, color=colour, zorder=3)
        if np.isfinite(row.truth):
            ax.plot([row.truth], [y], marker="|", markersize=8, markeredgewidth=1.4, color=INK, zorder=4)
        if np.isfinite(row.estimate):  # none where the reward is bounded on one side only (its bound is the answer)
            ax.plot([row.estimate], [y], marker="o", markersize=3.5, markerfacecolor="white",
                    markeredgecolor=INK, markeredgewidth=0.9, zorder=5)
    ax.set_xscale("symlog", linthresh=linthresh, linscale=0.5)
    ticks = symlog_ticks(limit, linthresh=linthresh, ends=False)
    if limit > 2 * max(ticks) and len(ticks) > 5:
        # A bound past the last power of ten squeezes the decades: "−1000" would touch "−100".
        ticks = [t for t in ticks if t == 0 or round(math.log10(abs(t))) % 2 == 1]
    ax.set_xticks(ticks, [value_label(t) for t in ticks])
    ax.xaxis.set_minor_locator(_no_minor())
    ax.set_xlim(-limit * 2.5, limit * 2.5)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_yticks(range(len(rows)), [row.label for row in rows])
    ax.tick_params(axis="y", length=0)
    ax.axvline(0, color="#bbbbbb", linewidth=0.5, zorder=1)
    ax.grid(axis="x", color="#e6e6e6", linewidth=0.4, zorder=0)
    ax.set_axisbelow(True)
    ax.set_xlabel("reward (symmetric-log axis)", labelpad=2)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    if title:
        ax.set_title(title, pad=3, wrap=True)  # a long world name in it would run off the figure


def _no_minor():
    from matplotlib.ticker import NullLocator

    return NullLocator()


def interval_legend(rows: Sequence[IntervalRow], *, kind: str, confidence: float | None,
                    rmax: float | None) -> list:
    """Legend entries: the dot, the tick, and the triangle when an end is at ±rmax (the kind is its title)."""
    one_sided = any(not np.isfinite(row.estimate) for row in rows)
    handles = [Line2D([], [], linestyle="", marker="o", markersize=3.5, markerfacecolor="white",
                      markeredgecolor=INK, label="estimate (none where bounded on one side)" if one_sided else "estimate")]
    if any(np.isfinite(row.truth) for row in rows):
        handles.append(Line2D([], [], linestyle="", marker="|", markersize=8, markeredgewidth=1.4,
                              color=INK, label="truth"))
    if rmax is not None and any(at_bound(row.low, rmax) or at_bound(row.high, rmax) for row in rows):
        # An identified set's end on the box is no bound at all; a confidence interval's is the box's.
        meaning = "no bound" if kind == "identified" else "the fit's bound"
        handles.append(Line2D([], [], linestyle="", marker=">", markersize=4, color="#777777",
                              label=f"at ±{value_label(rmax)}: {meaning}"))
    return handles


def interval_figure(panels: Sequence[tuple[str, Sequence[IntervalRow]]], *, kind: str,
                    confidence: float | None = None, rmax: float | None, linthresh: float = LINTHRESH,
                    width: float = PANEL_WIDTH) -> Figure:
    """Interval panels stacked on one shared axis (e.g. one per world), with one legend.

    Args:
        panels: (title, rows) per panel; rows are drawn worst symbol first (`worst_first`).
        kind: "identified" (the lp's identified set) or "confidence" (with `confidence`, e.g. 0.95).
        rmax: the fit's bound |R_S| <= rmax: the axis runs to it, and ends on it are marked;
            None when it is not known (the axis then ends just beyond the values).
    """
    every_row = [row for _, rows in panels for row in rows]
    legend = interval_legend(every_row, kind=kind, confidence=confidence, rmax=rmax)
    with figure_style():
        heights = [max(len(rows), 1) for _, rows in panels]
        height = FRAME_HEIGHT + 0.35 * (len(panels) - 1) + ROW_HEIGHT * sum(heights) + LEGEND_HEIGHT
        figure = new_figure(width, height)
        axes = figure.subplots(len(panels), 1, squeeze=False, sharex=True,
                               gridspec_kw={"height_ratios": heights})[:, 0]
        for ax, (title, rows) in zip(axes, panels):
            draw_intervals(ax, worst_first(rows), rmax=rmax, linthresh=linthresh, title=title)
        for ax in axes[:-1]:
            ax.set_xlabel("")
        figure.legend(handles=legend, loc="outside lower center", ncol=len(legend), handlelength=1.2,
                      columnspacing=0.9, handletextpad=0.3, title=f"bars: {kind_label(kind, confidence)}",
                      title_fontsize=6)
    return figure
