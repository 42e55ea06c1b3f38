"""A reach fit in text: printed (each symbol's fitted points and interval beside the world's, the spread law, the
player), and the fit view's pictures (`ReachField`: the field with the reaches at sub-cell resolution;
`ReachIntervals`: each symbol's interval on the reward colours' axis). What the figure and the view share
(the optima, the part of the field drawn, the distance to the penalty) is here too, free of matplotlib."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rich.console import Console, ConsoleOptions, RenderResult
from rich.style import Style
from rich.table import Table
from rich.text import Text

from careful_tui.render.grid import OTHER_SYMBOL_COLOUR, SYMBOL_COLOURS, diverging_colour, format_value
from careful_tui.render.intervals import axis_ticks, interval_bar, interval_span
from irl_core.irl.intervals.honest import one_sided
from irl_core.reach.fit import RMAX, ReachFit
from irl_core.reach.gain import best_choice, choice_grid
from irl_core.support.plural import plural
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.reach import ReachWorld


@dataclass(frozen=True)
class Optima:
    """The expected-gain maximiser's (aim (2,), duration ms) for the fitted points (None when some symbol's
    points may be any value: its fitted value is where a search stopped, and so is that choice) and for the
    world's own."""

    fitted: tuple[np.ndarray, float] | None
    true: tuple[np.ndarray, float]

    @property
    def shown(self) -> list[tuple[tuple[np.ndarray, float], str]]:
        """The choices to draw, each with whose it is ("fitted", then "true")."""
        return [(choice, name) for choice, name in ((self.fitted, "fitted"), (self.true, "true")) if choice is not None]


def optima(fit: ReachFit) -> Optima:
    """Both optimal choices, on the grid the fit reasoned over (its spread law)."""
    grid = choice_grid(fit.world, spread=fit.spread.spread)
    world = fit.world
    unbounded = any(low <= -RMAX and high >= RMAX for low, high in fit.interval.values())
    return Optima(None if unbounded else best_choice(grid, [fit.reward[s] for s in world.symbols]),
                  best_choice(grid, [world.points[s] for s in world.symbols]))


def penalty_symbols(world: ReachWorld) -> list[str]:
    """The symbols whose distance the durations are drawn against: those of the lowest points (the penalty)."""
    lowest = min(world.points.values())
    return [symbol for symbol, points in world.points.items() if points == lowest]


def penalty_distance(world: ReachWorld, aims: np.ndarray) -> np.ndarray:
    """(n,) the distance of each aim (n, 2) from the nearest rim of a penalty circle (below 0: inside it)."""
    symbols = penalty_symbols(world)
    circles = [region for region in world.regions if region.symbol in symbols]
    return np.min([np.hypot(*(aims - np.asarray(c.centre)).T) - c.radius for c in circles], axis=0)


def view_box(world: ReachWorld) -> tuple[np.ndarray, np.ndarray]:
    """The field's part drawn: the circles' bounding box widened by the largest radius, inside the field."""
    centres = np.array([region.centre for region in world.regions])
    radii = np.array([region.radius for region in world.regions])
    low = np.maximum((centres - radii[:, None]).min(axis=0) - radii.max(), 0.0)
    high = np.minimum((centres + radii[:, None]).max(axis=0) + radii.max(), np.asarray(world.field))
    return low, high


def point_sides(fit: ReachFit) -> dict[str, int]:
    """Per symbol: -1 where its interval is open below only (read "at most" its top), +1 open above only
    ("at least" its bottom), 0 otherwise. A symbol bounded on one side has no point: its bound is the answer."""
    sides = one_sided(np.array([fit.interval[symbol] for symbol in fit.reward], dtype=float).reshape(-1, 2), RMAX)
    return {symbol: int(side) for symbol, side in zip(fit.reward, sides)}


def has_point(fit: ReachFit, symbol: str) -> bool:
    """Whether a symbol's fitted value is shown as a point: not when its interval is open on one side (its bound
    is the answer) or on both (the whole range: the value is where a search stopped on a flat likelihood)."""
    low, high = fit.interval[symbol]
    return point_sides(fit)[symbol] == 0 and not (low <= -RMAX and high >= RMAX)


def shown_points(fit: ReachFit, symbol: str) -> str:
    """A symbol's fitted points as every view shows them: the value, its bound ("≤-230") when bounded on one
    side only, or "any" when on neither."""
    low, high = fit.interval[symbol]
    if has_point(fit, symbol):
        return format_value(fit.reward[symbol])
    side = point_sides(fit)[symbol]
    return f"≤{format_value(high)}" if side < 0 else f"≥{format_value(low)}" if side > 0 else "any"


def reach_fit_title(fit: ReachFit) -> str:
    """"reach fit of reach: 100 trials from 1 file" (the world's name shown as written)."""
    return (f"reach fit of {printable(fit.world.name, limit=VALUE_LIMIT)}: {plural(fit.trials, 'trial')} "
            f"from {plural(fit.files, 'file')}")


def print_reach_fit(console: Console, fit: ReachFit) -> None:
    """The fit as a table of symbols, then a line each for the spread law, the player and every note."""
    kind = (f"{fit.confidence:.0%} confidence (Laplace)" if fit.interval_kind == "confidence"
            else "identified set (every value the choices allow)")
    console.print(Text(reach_fit_title(fit)), soft_wrap=True)
    table = Table()
    for column in ("symbol", "fitted points", f"interval: {kind}", "the world's points"):
        table.add_column(column)
    for symbol in fit.reward:
        low, high = fit.interval[symbol]
        table.add_row(printable(symbol), shown_points(fit, symbol), f"{format_value(low)} to {format_value(high)}",
                      format_value(fit.world.points[symbol]))
    console.print(table)
    console.print(Text(spread_line(fit)), soft_wrap=True)
    if fit.beta is not None and fit.aim_sd is not None:
        console.print(Text(f"player: soft-optimal, beta {fit.beta:.3g}, aim noise sd {fit.aim_sd:.3g}"), soft_wrap=True)
    for note in fit.notes:
        console.print(Text(f"note ({note.code}): {note.text}", style="yellow"), soft_wrap=True)


def spread_line(fit: ReachFit) -> str:
    """The spread law in a line: whose it is, its a and b, and their intervals when fitted."""
    law = fit.spread.spread
    where = "the world's own" if fit.spread.known else "fitted to the endpoints"
    line = f"spread law ({where}): sd = {law.a:.3g} + {law.b:.3g} x distance / seconds"
    if fit.spread.interval is not None:
        (a_low, a_high), (b_low, b_high) = fit.spread.interval["a"], fit.spread.interval["b"]
        line += f"  (a {a_low:.3g} to {a_high:.3g}, b {b_low:.3g} to {b_high:.3g})"
    return line


# Braille cells: each character holds 2 x 4 dots; the bit of dot (column, row).
_BRAILLE_BASE = 0x2800
_BRAILLE_BITS = ((0x01, 0x02, 0x04, 0x40), (0x08, 0x10, 0x20, 0x80))
FITTED_MARK, TRUE_MARK, BOTH_MARK = "◆", "◇", "◈"
MAX_FIELD_COLUMNS = 60  # about 24 rows for the built-ins: the intervals fit below it in 45 rows


@dataclass
class ReachField:
    """The field around its circles, a character wide per `step` field units: each character's background is
    the circle holding its centre (the world's colours; two overlapping, the overlap's), each recorded endpoint
    a braille dot (2 x 4 a character: sub-cell resolution), ◆ the best aim for the fitted points and ◇ for the
    world's (◈ both). It takes the width it is given, up to MAX_FIELD_COLUMNS."""

    fit: ReachFit
    endpoints: np.ndarray
    best: Optima

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        world = self.fit.world
        low, high = view_box(world)
        columns = max(20, min(options.max_width, MAX_FIELD_COLUMNS))
        step = float(high[0] - low[0]) / columns
        rows = max(4, round(float(high[1] - low[1]) / (2 * step)))  # a character is about twice as tall as wide
        dots = np.zeros((rows, columns), dtype=int)
        cell = (self.endpoints - low) / np.array([step, 2 * step])  # in characters
        inside = np.all((cell >= 0) & (cell < [columns, rows]), axis=1)
        for x, y in cell[inside]:
            column, row = int(x), int(y)
            dots[row, column] |= _BRAILLE_BITS[min(int((x - column) * 2), 1)][min(int((y - row) * 4), 3)]
        marks: dict[tuple[int, int], str] = {}
        for (aim, _), name in self.best.shown:
            mark = FITTED_MARK if name == "fitted" else TRUE_MARK
            x, y = (aim - low) / np.array([step, 2 * step])
            if 0 <= x < columns and 0 <= y < rows:
                marks[int(y), int(x)] = BOTH_MARK if (int(y), int(x)) in marks else mark
        for row in range(rows):
            line = Text(no_wrap=True, overflow="crop")
            for column in range(columns):
                centre = (float(low[0]) + (column + 0.5) * step, float(low[1]) + (row + 0.5) * 2 * step)
                held = world.regions_holding(centre)
                background = (None if not held else SYMBOL_COLOURS.get(held[0], OTHER_SYMBOL_COLOUR) if len(held) == 1
                              else "#5a3a6a")
                if (row, column) in marks:
                    # white behind the mark: it shows on every circle's colour and on the ground
                    line.append(marks[row, column], Style(color="#c0392b", bold=True, bgcolor="#ffffff"))
                elif dots[row, column]:
                    line.append(chr(_BRAILLE_BASE + dots[row, column]), Style(color="#ffffff", bgcolor=background))
                else:
                    line.append(" ", Style(bgcolor=background))
            yield line
        outside = int((~inside).sum())
        yield Text(f"x {low[0]:g} to {high[0]:g}, y {low[1]:g} to {high[1]:g} (down); the start is at "
                   f"{list(world.start)}" + (f"; {plural(outside, 'endpoint')} outside this view" if outside else ""),
                   style="dim")
        key = Text("⣿ endpoints  ", style="dim")
        key.append(f"{FITTED_MARK} best aim, fitted points  {TRUE_MARK} the world's  {BOTH_MARK} both  "
                   if self.best.fitted is not None else f"{TRUE_MARK} best aim, the world's points (none for the "
                   "fitted: some symbol's points may be any value)  ", style="dim")
        for symbol in world.symbols:
            key.append("  ", Style(bgcolor=SYMBOL_COLOURS.get(symbol, OTHER_SYMBOL_COLOUR)))
            key.append(f" {printable(symbol)} {shown_points(self.fit, symbol)}  ")
        yield key


@dataclass
class ReachIntervals:
    """Each fitted symbol's interval as a bar on the signed-log axis of the reward colours, from -rmax to rmax,
    as the grid fits' `IntervalChart`: ● fitted (none where bounded on one side), ○ the world's, ◀ ▶ no bound."""

    fit: ReachFit

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        fit = self.fit
        fitted = [symbol for symbol, (low, high) in fit.interval.items() if low != high]
        spans = {symbol: interval_span(*fit.interval[symbol], RMAX) for symbol in fitted}
        width = max(map(len, spans.values()), default=0)
        room = options.max_width - width - 7
        axis = max(21, room if room % 2 else room - 1)
        for symbol in sorted(fitted, key=lambda s: fit.interval[s][1]):
            low, high = fit.interval[symbol]
            line = Text(f"{printable(symbol)}  ", no_wrap=True, overflow="crop")
            line.append("◀" if low <= -RMAX else " ", style="bold")
            line.append_text(interval_bar(axis, RMAX, low, high, fit.reward[symbol] if has_point(fit, symbol) else None,
                                          fit.world.points[symbol]))
            line.append("▶" if high >= RMAX else " ", style="bold")
            line.append(f"  {spans[symbol]:>{width}}", style="bold")
            yield line
        yield Text("    ") + axis_ticks(axis, RMAX)
        what = f"{fit.confidence:.0%} confidence" if fit.interval_kind == "confidence" else "allowed"
        yield Text.assemble("    ", ("● fitted if bounded both ways  ○ true  ◉ both  ", "dim"),
                            ("━", diverging_colour(-RMAX, RMAX)), ("━", diverging_colour(RMAX, RMAX)),
                            (f" {what}  ◀ ▶ no bound", "dim"))
