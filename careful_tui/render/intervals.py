"""How far the demonstrations pin each fitted reward: a table, a chart and a sentence per symbol.

`interval_readings` puts an interval into words ("cliff: at most -661; no lower bound;
catastrophic next to mud's ..."); `IntervalChart` draws every unknown's interval as a bar on
the signed-log axis of the reward colours. The `careful fit` printout and the fit screen share them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from rich.console import Console, ConsoleOptions, JustifyMethod, RenderResult
from rich.style import Style
from rich.table import Table
from rich.text import Text

from careful_tui.render.grid import LINEAR_THRESHOLD, SYMBOL_NAMES, diverging_colour, format_value, signed_log_fraction
from irl_core.irl import FitResult, at_bound
from irl_core.irl.intervals.honest import bounded_cells, one_sided


def interval_table(result: FitResult) -> Table:
    """One row per unknown: fitted and true values, the interval and what it means."""
    rmax = result.rmax
    intervals = result.intervals
    assert intervals is not None, "a fit with intervals"
    table = Table(title=interval_title(result))
    columns: tuple[tuple[str, JustifyMethod], ...] = (("unknown", "left"), ("fitted", "right"), ("true", "right"),
                                                      ("low", "right"), ("high", "right"), ("reading", "left"))
    for name, justify in columns:
        table.add_column(name, justify=justify)
    truth = result.true_theta() if result.world.rewards else np.full(len(result.labels), np.nan)
    sides = one_sided(intervals, rmax)
    for label, value, true, side, (low, high) in zip(result.labels, result.theta, truth, sides, intervals):
        table.add_row(
            Text(label), fitted_cell(float(value), float(low), float(high), int(side)),
            "-" if np.isnan(true) else format_value(float(true)), format_value(float(low)), format_value(float(high)),
            interval_reading(low, high, rmax),
        )
    return table


def bound_labels(bounded: Mapping[tuple[int, int], tuple[int, float]],
                 number: Callable[[float], str] = format_value) -> dict[tuple[int, int], str]:
    """Each cell of `bounded` (`irl_core.irl.intervals.honest.bounded_cells`) as its bound in a grid's cell:
    "≤-14.6" (at most), "≥89.7" (at least), written by `number`."""
    return {cell: f"{'≤' if side < 0 else '≥'}{number(bound)}" for cell, (side, bound) in bounded.items()}


def shown_reward_grid(result: FitResult, number: Callable[[float], str] = format_value
                      ) -> tuple[np.ndarray, dict[tuple[int, int], str]]:
    """The fitted reward grid (rows, cols) as every front end shows it: a cell bounded on one side only has no
    value (NaN: no colour, since "at most 94" coloured as 94 would read as a reward) and its bound for words."""
    bounded = bounded_cells(result)
    grid = np.array(result.reward_grid, dtype=float, copy=True)
    for row, col in bounded:
        grid[row, col] = np.nan
    return grid, bound_labels(bounded, number)


def fitted_cell(value: float, low: float, high: float, side: int) -> str:
    """The fitted column: the point, or for a reward bounded on one side only its bound ("≤ -22.5"), since its
    point is where a search stopped on a flat likelihood, not an estimate."""
    if side < 0:
        return f"≤ {format_value(high)}"
    if side > 0:
        return f"≥ {format_value(low)}"
    return format_value(value)


def interval_title(result: FitResult) -> str:
    """What the intervals are: identified by the demonstrations (lp) or a confidence interval."""
    if result.interval_kind == "confidence" and result.player_model == "timing":
        grouped = result.demos.episode_groups is not None
        return (f"{result.options.confidence:.0%} confidence intervals (the likelihood's curvature, its spread "
                f"measured between {'participants' if grouped else 'episodes'})")
    if result.interval_kind == "confidence":
        options = result.options
        title = (f"{options.confidence:.0%} confidence intervals ({options.resamples} resamples of "
                 f"{result.demos.episodes} episodes{widened_by(result)})")
    else:
        title = "identified by the demonstrations: every value each reward can take" + (
            f" ({widened_by(result).removeprefix(', ')})" if widened_by(result) else "")
    return title


def widened_by(result: FitResult) -> str:
    """", joined with the rival planning model's, widened by careful check's calibration" as the intervals
    were (`FitResult.interval_method`), or ""."""
    method = result.interval_method or ""
    joined = ("every close player model's (--union)" if result.options.union or result.rival_model is None
              else f"the {result.rival_model} model's")
    words = [("+union", f"joined with {joined}"),
             ("+calibrated", "widened by careful check's calibration")]
    return "".join(f", {said}" for mark, said in words if mark in method)


def _open_ends(low: float, high: float, rmax: float) -> tuple[bool, bool]:
    """Whether each end of an interval sits at the ±rmax bound (no bound from the demonstrations)."""
    return bool(low < 0 and at_bound(low, rmax)), bool(high > 0 and at_bound(high, rmax))


def interval_reading(low: float, high: float, rmax: float) -> str:
    """A plain sentence for one interval; an end at ±rmax is no bound at all."""
    return _phrase(low, high, rmax, ("not bounded by the demonstrations", "at most {high}; no lower bound",
                                     "at least {low}; no upper bound", "between {low} and {high}"))


def interval_span(low: float, high: float, rmax: float) -> str:
    """An interval in a few characters: "-49.3..-14.8", "≤ -661", "≥ 89.7", "any"."""
    return _phrase(low, high, rmax, ("any", "≤ {high}", "≥ {low}", "{low}..{high}"))


def _phrase(low: float, high: float, rmax: float, phrases: tuple[str, str, str, str]) -> str:
    """One of `phrases` (both ends open, low open, high open, both bounded) with the ends filled in."""
    open_low, open_high = _open_ends(low, high, rmax)
    phrase = phrases[0 if open_low and open_high else 1 if open_low else 2 if open_high else 3]
    return phrase.format(low=format_value(low), high=format_value(high))


def symbol_name(symbol: str) -> str:
    return SYMBOL_NAMES.get(symbol, symbol)


def symbol_intervals(result: FitResult) -> dict[str, tuple[float, float]]:
    """Per symbol (in the order the unknowns first use it): the lowest low and highest high of its unknowns."""
    assert result.intervals is not None, "a fit with intervals"
    hulls: dict[str, tuple[float, float]] = {}
    for symbol, (low, high) in zip(result.unknowns.symbols, result.intervals):
        old_low, old_high = hulls.get(symbol, (np.inf, -np.inf))
        hulls[symbol] = (min(old_low, float(low)), max(old_high, float(high)))
    return hulls


def _low_to_high(hulls: dict[str, tuple[float, float]]) -> list[str]:
    """Symbols by the top of their interval, then its bottom."""
    return sorted(hulls, key=lambda symbol: (hulls[symbol][1], hulls[symbol][0]))


# A symbol whose every allowed value is this many times below another's worst is "catastrophic next to" it.
CATASTROPHIC_RATIO = 10.0


def interval_readings(result: FitResult) -> list[str]:
    """One sentence per symbol, lowest first: its interval and how it stands against the next symbol up.

    e.g. "cliff: at most -661; no lower bound; catastrophic next to mud's -49.3..-14.8 (at least
    13× worse under every reward the demonstrations allow)"; with confidence intervals the ratio
    compares their ends ("end to end of their 95% confidence intervals"): each interval is 95%
    sure on its own, their ratio is not. A symbol's interval spans those of all its cells.
    """
    rmax = result.rmax
    confident = result.interval_kind == "confidence"
    sure = (f"end to end of their {result.options.confidence:.0%} confidence intervals" if confident
            else "under every reward the demonstrations allow")
    hulls = symbol_intervals(result)
    order = _low_to_high(hulls)
    lines = []
    for below, above in zip(order, [*order[1:], None]):
        low, high = hulls[below]
        line = f"{symbol_name(below)}: {interval_reading(low, high, rmax)}"
        if above is not None:
            above_low, above_high = hulls[above]
            other = f"{symbol_name(above)}'s {interval_span(above_low, above_high, rmax)}"
            ratio = high / above_low if high < above_low < 0 else 0.0
            if high >= above_low:
                who = "at this confidence the data" if confident else "the demonstrations"
                line += f"; overlaps {other}: {who} cannot tell which is worse"
            elif ratio >= CATASTROPHIC_RATIO:
                line += f"; catastrophic next to {other} (at least {ratio:.0f}× worse {sure})"
            elif ratio > 0:
                line += f"; at least {ratio:.1f}× worse than {other}{', ' + sure if confident else ''}"
            else:
                line += f"; below {other}"
        lines.append(line)
    return lines


@dataclass
class IntervalChart:
    """Every unknown's interval as a bar on the reward colours' signed-log axis, from -rmax to rmax.

    ● marks the fitted value, ○ the world's own (◉ both); ◀ or ▶ just outside the axis means the
    demonstrations do not bound it there (the bar runs into ±rmax): outside, so a mark at that
    end cannot hide it. Rows are grouped by symbol,
    lowest symbol first (as `interval_readings`). The bars take the width they are given.
    """

    result: FitResult

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        result = self.result
        intervals = result.intervals
        assert intervals is not None, "a fit with intervals"
        rmax = float(result.rmax)
        true = result.true_theta() if result.world.rewards else None
        symbols = _low_to_high(symbol_intervals(result))
        rows = sorted(range(len(result.labels)), key=lambda j: (symbols.index(result.unknowns.symbols[j]), j))
        spans = [interval_span(float(lo), float(hi), rmax) for lo, hi in intervals]
        sides = one_sided(np.asarray(intervals, dtype=float), rmax)
        # Tied unknowns are named by their symbol: "cliff" reads better than "C".
        labels = [symbol_name(s) for s in result.unknowns.symbols] if result.options.tie else result.labels
        label_width = max(map(len, labels), default=0)
        span_width = max(map(len, spans), default=0)
        # An odd number of positions puts 0 in the middle.
        room = options.max_width - label_width - span_width - 6
        axis = max(21, room if room % 2 else room - 1)
        for j in rows:
            low, high = (float(v) for v in intervals[j])
            open_low, open_high = _open_ends(low, high, rmax)
            line = Text(f"{labels[j]:<{label_width}}  ", no_wrap=True, overflow="crop")
            line.append("◀" if open_low else " ", style="bold")
            # A reward bounded on one side only is its bound: no point is marked as its estimate.
            fitted = None if sides[j] else float(result.theta[j])
            line.append_text(interval_bar(axis, rmax, low, high, fitted, None if true is None else float(true[j])))
            line.append("▶" if open_high else " ", style="bold")
            line.append(f"  {spans[j]:>{span_width}}", style="bold")
            yield line
        indent = " " * (label_width + 3)
        yield Text(indent) + axis_ticks(axis, rmax)
        fitted_key = "● fitted if two-sided  " if sides.any() else "● fitted  "
        yield Text.assemble(indent, (f"{fitted_key}○ true  ◉ both  ", "dim"),
                            ("━", diverging_colour(-rmax, rmax)), ("━", diverging_colour(rmax, rmax)),
                            (f" {self._what()}  ◀ ▶ no bound", "dim"))

    def _what(self) -> str:
        if self.result.interval_kind == "confidence":
            return f"{self.result.options.confidence:.0%} confidence"
        return "allowed"


def interval_bar(axis: int, rmax: float, low: float, high: float, fitted: float | None, true: float | None) -> Text:
    """One interval as `axis` characters of the signed-log axis from -rmax to rmax: the bar in the reward colours,
    ● the fitted value (None: none, bounded on one side only), ○ the true one, ◉ both."""

    def at(value: float) -> int:
        return round((signed_log_fraction(value, rmax) + 1) / 2 * (axis - 1))

    chars = ["─"] * axis
    styles = [Style(color="#3a4452")] * axis
    chars[axis // 2] = "┼"
    start, end = at(low), at(high)
    for i in range(start, end + 1):
        chars[i] = "━"
        value = signed_log_value(i / (axis - 1) * 2 - 1, rmax)
        styles[i] = Style(color=diverging_colour(value, rmax), bold=True)
    marks = {} if fitted is None else {at(fitted): "●"}
    if true is not None:
        marks[at(true)] = "◉" if at(true) in marks else "○"
    for i, glyph in marks.items():
        chars[i] = glyph
        styles[i] = Style(color="#ffffff", bold=True)
    text = Text()
    for char, style in zip(chars, styles):
        text.append(char, style)
    return text


def signed_log_value(fraction: float, scale: float) -> float:
    """The value that `careful_tui.render.grid.signed_log_fraction` maps to `fraction` in [-1, 1]."""
    return float(np.sign(fraction) * LINEAR_THRESHOLD * np.expm1(abs(fraction) * np.log1p(scale / LINEAR_THRESHOLD)))


def axis_ticks(axis: int, rmax: float) -> Text:
    """Labels under the axis: -rmax, the powers of ten between, 0 and up to rmax, where they fit."""
    powers = [10.0**k for k in range(1, 16) if 10.0**k < rmax / 2]
    values = [-rmax, *(-p for p in reversed(powers)), 0.0, *powers, rmax]
    line = [" "] * axis
    for value in values:
        label = format_value(value)
        centre = round((signed_log_fraction(value, rmax) + 1) / 2 * (axis - 1))
        left = min(max(0, centre - len(label) // 2), axis - len(label))
        span = range(max(0, left - 1), min(axis, left + len(label) + 1))
        if all(line[i] == " " for i in span):
            line[left : left + len(label)] = label
    return Text("".join(line), style="dim")


def scale_legend(scale: float, steps: int = 4) -> Text:
    """The colour scale in a few characters: "-1000 ■■■■■■■■■ 1000" (signed-log, as the cells)."""
    fractions = [i / steps for i in range(-steps, steps + 1)]
    text = Text(f"{format_value(-scale)} ")
    for f in fractions:
        text.append("■", style=diverging_colour(signed_log_value(f, scale), scale))
    text.append(f" {format_value(scale)}")
    return text
