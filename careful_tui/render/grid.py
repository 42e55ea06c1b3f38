"""One picture of a world, used everywhere a grid is drawn.

`WorldGrid` is a Rich renderable: the `careful fit` printout prints it, the play,
replay and fit screens put it in a widget, and SVG export records it. Cells are
coloured by symbol, or by a value on a diverging scale whose magnitude is
compressed logarithmically, so that -1000 and -30 both read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import ROUND_HALF_UP, Decimal

import numpy as np
from rich.console import Console, ConsoleOptions, RenderResult
from rich.measure import Measurement
from rich.segment import Segment
from rich.style import Style
from rich.text import Text

from irl_core.irl.identification import MOVE
from irl_core.worlds.world import WALL, Cell, World

SYMBOL_COLOURS: dict[str, str] = {
    ".": "#3b4a3f",  # ground
    "C": "#8b1e1e",  # cliff
    "G": "#c9a227",  # goal
    "U": "#6b4f2a",  # mud: undesirable
    WALL: "#1c1c1c",
}
SYMBOL_NAMES: dict[str, str] = {".": "ground", "C": "cliff", "G": "goal", "U": "mud", WALL: "wall", MOVE: "a move"}
ARROWS: dict[str, str] = {"up": "↑", "right": "→", "down": "↓", "left": "←"}
OTHER_SYMBOL_COLOUR = "#4a4a6a"
# ColorBrewer's RdBu (11 classes), as the figures draw rewards (`render.figures.heatmap`): red below
# zero, blue above, near white at zero. Red and blue, not red and green, so the one in twelve men
# who cannot tell red from green still can.
RDBU = ("#67001f", "#b2182b", "#d6604d", "#f4a582", "#fddbc7", "#f7f7f7", "#d1e5f0", "#92c5de", "#4393c3",
        "#2166ac", "#053061")
# Values below this magnitude are drawn almost neutral; above it the colour grows with log|v|.
LINEAR_THRESHOLD = 1.0


def signed_log_fraction(value: float, scale: float) -> float:
    """value mapped to [-1, 1] by sign(v) log(1 + |v|/t) / log(1 + scale/t)."""
    if not math.isfinite(value) or scale <= 0:
        return 0.0
    top = math.log1p(scale / LINEAR_THRESHOLD)
    return max(-1.0, min(1.0, math.copysign(math.log1p(abs(value) / LINEAR_THRESHOLD) / top, value)))


def diverging_colour(value: float, scale: float) -> str:
    """A hex colour on RdBu: red below zero, blue above, near white at zero; intensity on a log scale."""
    position = (1 + signed_log_fraction(value, scale)) / 2 * (len(RDBU) - 1)  # RDBU[0] is the most negative
    low = min(int(position), len(RDBU) - 2)
    a, b = (tuple(int(RDBU[i][k:k + 2], 16) for k in (1, 3, 5)) for i in (low, low + 1))
    mix = [round(x + (y - x) * (position - low)) for x, y in zip(a, b)]
    return "#{:02x}{:02x}{:02x}".format(*mix)


def format_value(value: float) -> str:
    """A short label for a reward: -1000, -31.5, 0, 100."""
    if not math.isfinite(value):
        return "?"
    if abs(value) >= 100 or value == round(value):
        return f"{value:.0f}"
    return f"{value:.1f}"


def text_on(background: str) -> str:
    """Black or white, whichever reads on `background` (#rrggbb)."""
    r, g, b = (int(background[i : i + 2], 16) for i in (1, 3, 5))
    return "#000000" if 0.299 * r + 0.587 * g + 0.114 * b > 150 else "#ffffff"


@dataclass
class WorldGrid:
    """A world drawn as coloured cells, `cell_width` x `cell_height` characters each.

    Args:
        world: the layout to draw.
        values: (rows, cols) numbers to colour and print in the cells (NaN: none), e.g. a
            fitted R_S; without it cells are coloured by symbol.
        scale: the magnitude that gets the strongest colour (default: the largest |value|).
        labels: text per cell drawn on the cell's last line (e.g. "→8" for a policy).
        overlays: lines of text per cell that replace the cell's contents (the player's arrow).
        highlight: cells drawn with a bright frame colour (the player, a slip).
    """

    world: World
    values: np.ndarray | None = None
    scale: float | None = None
    labels: Mapping[Cell, str] = field(default_factory=dict)
    overlays: Mapping[Cell, list[Text]] = field(default_factory=dict)
    highlight: Mapping[Cell, str] = field(default_factory=dict)
    cell_width: int = 7
    cell_height: int = 3

    def background(self, cell: Cell) -> str:
        symbol = self.world.symbol(cell)
        if self.values is not None and symbol != WALL and np.isfinite(self.values[cell]):
            return diverging_colour(float(self.values[cell]), self._scale())
        return SYMBOL_COLOURS.get(symbol, OTHER_SYMBOL_COLOUR)

    def _scale(self) -> float:
        if self.scale is not None:
            return self.scale
        finite = self.values[np.isfinite(self.values)] if self.values is not None else np.zeros(0)
        return float(np.abs(finite).max()) if finite.size else 1.0

    def cell_lines(self, cell: Cell) -> list[Text]:
        """The cell's `cell_height` lines of text, each `cell_width` wide."""
        w, h = self.cell_width, self.cell_height
        bg = self.background(cell)
        base = Style(bgcolor=bg, color=text_on(bg))
        symbol = self.world.symbol(cell)
        if cell in self.overlays:
            content = list(self.overlays[cell])
        else:
            content = [Text(symbol if symbol not in (".", WALL) else "", style=base + Style(dim=True))]
            if self.values is not None and symbol != WALL and np.isfinite(self.values[cell]):
                content.append(Text(format_value(float(self.values[cell])), style=base + Style(bold=True)))
            if cell in self.labels:  # a label's lines, each its own line of the cell
                content.extend(Text(part, style=base) for part in self.labels[cell].split("\n"))
        content = content[:h]
        top = (h - len(content)) // 2
        lines = [Text(" " * w, style=base) for _ in range(h)]
        for i, text in enumerate(content):
            line = text.copy()
            line.truncate(w)
            line.pad_left((w - line.cell_len) // 2)
            line.pad_right(w - line.cell_len)
            # Under the overlay's own colours, not over them.
            line.stylize_before(base, 0, len(line))
            line.style = base
            lines[top + i] = line
        if cell in self.highlight:
            frame = Style(color=self.highlight[cell], bgcolor=bg, bold=True)
            if h >= 3:
                lines[0] = Text("▛" + "▀" * (w - 2) + "▜", style=frame)
                lines[-1] = Text("▙" + "▄" * (w - 2) + "▟", style=frame)
            else:  # too low for a frame: a bar at each end of each line
                lines = [Text("▐", style=frame) + line[1:w - 1] + Text("▌", style=frame) for line in lines]
        return lines

    def cell_segments(self, cell: Cell, console: Console) -> list[list[Segment]]:
        """The cell's `cell_height` lines as segments."""
        # Text.render drops Text.style when a line has no spans: apply it here.
        return [
            list(Segment.apply_style(line.render(console), console.get_style(line.style)))
            for line in self.cell_lines(cell)
        ]

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        # A world wider than the space is drawn in strips of whole columns, one under the other, each
        # named; cut at the edge, a 24-wide world's printout showed 11 columns and said nothing of the rest.
        cols = self.world.cols
        strips = math.ceil(cols / max(1, options.max_width // self.cell_width))
        per_strip = math.ceil(cols / strips)  # strips of about one width: 8, 8, 8 rather than 11, 11, 2
        for first in range(0, cols, per_strip):
            last = min(cols, first + per_strip)
            if strips > 1:
                yield Text(f"columns {first} to {last - 1} (of 0 to {cols - 1})", style="dim")
            for r in range(self.world.rows):
                row = [self.cell_segments((r, c), console) for c in range(first, last)]
                for i in range(self.cell_height):
                    for lines in row:
                        yield from lines[i]
                    yield Segment.line()

    def __rich_measure__(self, console: Console, options: ConsoleOptions):
        return Measurement(self.cell_width, self.world.cols * self.cell_width)


def symbol_legend(world: World) -> Text:
    """A one-line key to the symbols the world uses, with their colours and rewards."""
    legend = Text()
    seen = dict.fromkeys(ch for row in world.grid for ch in row)
    for symbol in seen:
        colour = SYMBOL_COLOURS.get(symbol, OTHER_SYMBOL_COLOUR)
        name = SYMBOL_NAMES.get(symbol, symbol)
        legend.append("  ", style=Style(bgcolor=colour))
        reward = f" {format_value(world.reward_of(symbol))}" if symbol in world.rewards else ""
        terminal = " (ends)" if symbol in world.terminal else ""
        legend.append(f" {name}{reward}{terminal}   ")
    return legend


def action_label(direction: str, level: int, *, levels: int) -> str:
    """An action as a cell label: "→8" (arrow, carefulness level), or "→" when the world has one level."""
    return f"{ARROWS[direction]}{level}" if levels > 1 else ARROWS[direction]


def format_chance(p: float) -> str:
    """A probability as a short percentage, halves rounded up: two significant digits from 1 %
    ("50%", "13%", "6.3%"), one below ("0.8%", "0.006%"), "<0.001%" below that; never shown as
    0 % or 100 % unless it is."""
    percent = Decimal(repr(100.0 * p))
    if percent <= 0 or percent >= 100:
        return f"{percent:.0f}%"
    if percent < Decimal("0.001"):
        return "<0.001%"
    digits = 2 if percent >= 1 else 1
    shown = percent.quantize(Decimal(1).scaleb(percent.adjusted() - digits + 1), rounding=ROUND_HALF_UP)
    if shown >= 100:
        return ">99%"
    return f"{shown.normalize():f}%"
