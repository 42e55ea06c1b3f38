"""A reach world's field drawn in text: each character shows the circles holding its centre, the start as ``S``."""

from __future__ import annotations

from rich.console import Console
from rich.style import Style
from rich.syntax import Syntax
from rich.text import Text

from careful_tui.render.grid import OTHER_SYMBOL_COLOUR, SYMBOL_COLOURS, format_value
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.reach import ReachWorld

# A terminal character is about twice as tall as it is wide: a row spans two columns' worth of field.
FIELD_COLUMNS = 60
OVERLAP = "+"


def field_text(world: ReachWorld, *, columns: int = FIELD_COLUMNS) -> Text:
    """The field as `columns` characters a row: a circle's symbol where one circle holds the character's
    centre, ``+`` where several overlap, ``S`` at the start and ``.`` elsewhere."""
    width, height = world.field
    step = width / columns
    rows = max(1, round(height / (2 * step)))
    start = (min(int(world.start[0] / step), columns - 1), min(int(world.start[1] / (height / rows)), rows - 1))
    text = Text()
    for row in range(rows):
        y = (row + 0.5) * height / rows
        for col in range(columns):
            x = (col + 0.5) * step
            held = world.regions_holding((x, y))
            if (col, row) == start:
                text.append("S", style="bold")
            elif len(held) > 1:
                text.append(OVERLAP, style=Style(bgcolor=SYMBOL_COLOURS.get("C", OTHER_SYMBOL_COLOUR)))
            elif held:
                colour = SYMBOL_COLOURS.get(held[0], OTHER_SYMBOL_COLOUR)
                text.append(printable(held[0]), style=Style(bgcolor=colour))
            else:
                text.append(".", style="dim")
        text.append("\n")
    return text


def print_reach_world(console: Console, world: ReachWorld) -> None:
    """The world's name and rules in a line, its field drawn, a key to its circles, and its TOML."""
    law = f"sd {world.spread.a:g} + {world.spread.b:g} x distance / seconds"
    console.print(Text.assemble(
        (printable(world.name, limit=VALUE_LIMIT), "bold"),
        f": a reach world, field {world.field[0]:g}x{world.field[1]:g}, {world.noise} noise ({law}), "
        f"costs {world.cost_per_second:g} a second, {world.min_ms:g} to {world.max_ms:g} ms"), soft_wrap=True)
    console.print(field_text(world), end="")
    legend = Text()
    for symbol, points in world.points.items():
        legend.append("  ", style=Style(bgcolor=SYMBOL_COLOURS.get(symbol, OTHER_SYMBOL_COLOUR)))
        legend.append(f" {printable(symbol)} {format_value(points)}   ")
    legend.append(f"{OVERLAP} circles overlap (points add)   S start")
    console.print(legend)
    console.print(Syntax(world.to_toml(), "toml", theme="ansi_dark", background_color="default", word_wrap=True))


def reach_table_rows(worlds: dict[str, ReachWorld]) -> list[tuple[str, ...]]:
    """Rows for `careful worlds`' table (name, size, levels, slip, rewards): a reach world's care is the reach."""
    return [(name, f"{world.field[0]:g}x{world.field[1]:g} field", "reach",
             f"sd {world.spread.a:g} + {world.spread.b:g} d/T",
             ", ".join(f"{symbol} {format_value(points)}" for symbol, points in world.points.items()))
            for name, world in worlds.items()]

