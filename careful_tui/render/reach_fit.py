"""A reach fit printed: each symbol's fitted points and interval beside the world's, the spread law, the player."""

from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.table import Table
from rich.text import Text

from careful_tui.render.grid import format_value
from irl_core.irl.intervals.honest import one_sided
from irl_core.reach.fit import RMAX, ReachFit
from irl_core.support.plural import plural
from irl_core.support.safe_text import VALUE_LIMIT, printable


def point_sides(fit: ReachFit) -> dict[str, int]:
    """Per symbol: -1 where its interval is open below only (read "at most" its top), +1 open above only
    ("at least" its bottom), 0 otherwise. A symbol bounded on one side has no point: its bound is the answer."""
    sides = one_sided(np.array([fit.interval[symbol] for symbol in fit.reward], dtype=float).reshape(-1, 2), RMAX)
    return {symbol: int(side) for symbol, side in zip(fit.reward, sides)}


def shown_points(fit: ReachFit, symbol: str) -> str:
    """A symbol's fitted points as every view shows them: the value, or its bound ("≤-230") when bounded on one
    side only."""
    side = point_sides(fit)[symbol]
    low, high = fit.interval[symbol]
    if side:
        return f"≤{format_value(high)}" if side < 0 else f"≥{format_value(low)}"
    return format_value(fit.reward[symbol])


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
    law = fit.spread.spread
    where = "the world's own" if fit.spread.known else "fitted to the endpoints"
    line = f"spread law ({where}): sd = {law.a:.3g} + {law.b:.3g} x distance / seconds"
    if fit.spread.interval is not None:
        (a_low, a_high), (b_low, b_high) = fit.spread.interval["a"], fit.spread.interval["b"]
        line += f"  (a {a_low:.3g} to {a_high:.3g}, b {b_low:.3g} to {b_high:.3g})"
    console.print(Text(line), soft_wrap=True)
    if fit.beta is not None and fit.aim_sd is not None:
        console.print(Text(f"player: soft-optimal, beta {fit.beta:.3g}, aim noise sd {fit.aim_sd:.3g}"), soft_wrap=True)
    for note in fit.notes:
        console.print(Text(f"note ({note.code}): {note.text}", style="yellow"), soft_wrap=True)
