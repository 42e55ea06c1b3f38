"""A reach world's field drawn in text: for `careful worlds --show`, each character shows the circles holding its
centre and the start as ``S``; for play (`field_pixels`), at twice that resolution in half-block characters, with
the aim, the ring of the endpoint's spread and the last endpoint."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from rich.console import Console
from rich.style import Style
from rich.syntax import Syntax
from rich.text import Text

from careful_tui.render.grid import OTHER_SYMBOL_COLOUR, SYMBOL_COLOURS, format_value
from careful_tui.render.palette import BAD, INK, NOTE, ON_NOTE, WARN, WHITE
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



# Play's field: a pixel is half a character (the upper half drawn by "▀" in its colour, the lower by the
# background), so that pixels are about square and a circle looks round.
HALF_BLOCK = "\u2580"
GROUND = "#1e2630"
RING_COLOURS = {"ok": WHITE, "short": WARN, "long": BAD}
AIM_MARK, END_MARK, START_MARK = "+", "\u00d7", "S"


def field_cells(world: ReachWorld, width: int, height: int) -> tuple[int, int]:
    """The (columns, rows) of characters play draws the field in, the largest that fits `width` x `height`
    with square pixels (two a character, one above the other)."""
    field_w, field_h = world.field
    unit = max(field_w / max(width, 1), field_h / (2 * max(height, 1)))
    return max(1, min(width, round(field_w / unit))), max(1, min(height, math.ceil(field_h / (2 * unit))))


def overlap_colour(world: ReachWorld) -> str:
    """Where circles overlap: the mean of the colours of the world's first two symbols (their points add)."""
    colours = [SYMBOL_COLOURS.get(symbol, OTHER_SYMBOL_COLOUR) for symbol in world.symbols[:2]]
    channels = [sum(int(colour[1 + 2 * k: 3 + 2 * k], 16) for colour in colours) // len(colours) for k in range(3)]
    return "#" + "".join(f"{channel:02x}" for channel in channels)


@dataclass(frozen=True)
class FieldMarks:
    """What play draws over the circles: the aim, the ring (its radius the endpoint's sd, and `within` the
    hold's limits: "ok", "short", "long"; None: no key held) and the last endpoint (None before any)."""

    aim: tuple[float, float]
    ring_sd: float | None = None
    within: str = "ok"
    endpoint: tuple[float, float] | None = None


def field_pixels(world: ReachWorld, columns: int, rows: int, marks: FieldMarks) -> Text:
    """The field as `rows` lines of `columns` half-block characters: the circles in their symbols' colours
    (overlaps in a blend), each circle's symbol at its centre, the start ``S``, the ring of radius
    `marks.ring_sd` around the aim, the aim ``+`` and the last endpoint ``×``."""
    field_w, field_h = world.field
    unit_x, unit_y = field_w / columns, field_h / (2 * rows)
    xs = (np.arange(columns) + 0.5) * unit_x
    ys = (np.arange(2 * rows) + 0.5) * unit_y
    px, py = np.meshgrid(xs, ys)
    colour = np.full(px.shape, GROUND, dtype=object)
    count = np.zeros(px.shape, dtype=int)
    for region in world.regions:
        inside = np.hypot(px - region.centre[0], py - region.centre[1]) <= region.radius
        colour[inside] = SYMBOL_COLOURS.get(region.symbol, OTHER_SYMBOL_COLOUR)
        count += inside
    colour[count > 1] = overlap_colour(world)
    if marks.ring_sd is not None and marks.ring_sd >= min(unit_x, unit_y) / 2:
        off = np.abs(np.hypot(px - marks.aim[0], py - marks.aim[1]) - marks.ring_sd)
        colour[off <= 0.5 * max(unit_x, unit_y)] = RING_COLOURS.get(marks.within, WHITE)

    def cell_of(point: tuple[float, float]) -> tuple[int, int]:
        return (min(int(point[0] / unit_x), columns - 1), min(int(point[1] / (2 * unit_y)), rows - 1))

    # Later marks win a shared character: the aim over the endpoint over the start over a circle's symbol. On
    # the ground a mark has its colour; on a circle (gold, red) it is dark, which reads on both.
    letters: dict[tuple[int, int], tuple[str, str]] = {}
    for region in world.regions:
        letters[cell_of(region.centre)] = (printable(region.symbol), INK)
    letters[cell_of(world.start)] = (START_MARK, INK)
    if marks.endpoint is not None:
        letters[cell_of(marks.endpoint)] = (END_MARK, WHITE)
    letters[cell_of(marks.aim)] = (AIM_MARK, NOTE)
    # Runs of one colour pair are appended at once: the field is redrawn at 30 Hz while a key is held.
    text = Text(no_wrap=True, overflow="crop")
    for row in range(rows):
        run, pair = 0, ("", "")
        for col in range(columns):
            top, bottom = colour[2 * row, col], colour[2 * row + 1, col]
            if (col, row) in letters or (top, bottom) != pair:
                if run:
                    text.append(HALF_BLOCK * run, style=_pixel_style(*pair))
                run, pair = 0, (top, bottom)
            if (col, row) in letters:
                letter, ink = letters[(col, row)]
                text.append(letter, style=f"bold {ink if bottom == GROUND else ON_NOTE} on {bottom}")
            else:
                run += 1
        if run:
            text.append(HALF_BLOCK * run, style=_pixel_style(*pair))
        if row < rows - 1:
            text.append("\n")
    return text


@lru_cache(maxsize=256)
def _pixel_style(top: str, bottom: str) -> Style:
    return Style(color=top, bgcolor=bottom)


def field_legend(world: ReachWorld) -> Text:
    """A key to play's field, short enough for the field's border at 80 columns: each symbol's colour and
    points, the overlap's blend, the marks."""
    legend = Text()
    for symbol, points in world.points.items():
        legend.append("\u25a0", style=SYMBOL_COLOURS.get(symbol, OTHER_SYMBOL_COLOUR))
        legend.append(f" {printable(symbol)} {format_value(points)}  ")
    if len(world.symbols) > 1:
        legend.append("\u25a0", style=overlap_colour(world))
        legend.append(f" {'+'.join(printable(symbol) for symbol in world.symbols[:2])}  ")
    legend.append(f"{AIM_MARK} aim  {END_MARK} landed")
    return legend
