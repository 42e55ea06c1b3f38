"""The board: a world drawn with `WorldGrid`, the player on it and the arrow of the move being
chosen, growing with the carefulness level. Play, replay and the fit view share it.

The cell size follows the space the widget gets: 7x3 characters at the least (an 80x24
terminal), up to 15x7.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from rich.console import Console, ConsoleOptions, RenderResult
from rich.segment import Segment
from rich.style import Style
from textual.reactive import reactive
from textual.widget import Widget

from careful_tui.grid import WorldGrid
from careful_tui.widgets.gauge import level_colour
from irl_core.mdp import DIRECTIONS, OFFSETS
from irl_core.world import World

Cell = tuple[int, int]
Mark = tuple[str, Style]

MIN_CELL = (7, 3)
MAX_CELL = (15, 7)
PLAYER_GLYPH = "●"
PLAYER_STYLE = Style(color="#ffffff", bold=True)
PLAYER_FRAME = "#aab8c8"
SLIP_COLOUR = "#ff9f1c"
CHECKER_SHADE = 0.82
# The longest arrow (level L) reaches this many cells beyond the player's centre.
ARROW_REACH = 1.5
# Shafts thicken with the level: thin, heavy, solid.
_SHAFTS = {"up": "│┃█", "down": "│┃█", "left": "─━▬", "right": "─━▬"}
_HEAD = {"up": "▲", "down": "▼", "left": "◀", "right": "▶"}


@dataclass(frozen=True)
class Arrow:
    """The move being chosen: a direction and a carefulness level (fractional while filling)."""

    direction: str
    level: float
    levels: int


def arrow_length(arrow: Arrow, cell_size: tuple[int, int]) -> int:
    """The arrow's length in characters, from next to the player's centre to its head."""
    w, h = cell_size
    vertical = arrow.direction in ("up", "down")
    longest = max(2, round(ARROW_REACH * (h if vertical else w)))
    shortest = 1 if vertical else 2
    return shortest + round(_fraction(arrow) * (longest - shortest))


def _fraction(arrow: Arrow) -> float:
    """Where the arrow's level lies between 1 (0.0) and L (1.0); 0.5 in a one-level world."""
    if arrow.levels <= 1:
        return 0.5
    return min(1.0, max(0.0, (arrow.level - 1) / (arrow.levels - 1)))


@dataclass
class BoardGrid(WorldGrid):
    """A `WorldGrid` with glyphs drawn at character positions inside cells.

    `marks[cell][(line, column)] = (glyph, style)` puts a glyph on a cell's background, so an
    arrow can run from the player's cell into its neighbours. It also gives every line its
    cell's background: `WorldGrid` renders a `Text` that has no spans without its style (blank
    cell lines, highlight frames), which Rich's `Text.render` leaves to the caller.
    """

    marks: Mapping[Cell, Mapping[tuple[int, int], Mark]] = field(default_factory=dict)

    def background(self, cell: Cell) -> str:
        """The symbol's colour, a shade darker on every other cell so that cells can be counted."""
        colour = super().background(cell)
        if self.values is None and sum(cell) % 2:
            return _darker(colour, CHECKER_SHADE)
        return colour

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        for r in range(self.world.rows):
            row = [((r, c), self.cell_lines((r, c))) for c in range(self.world.cols)]
            for i in range(self.cell_height):
                for cell, lines in row:
                    line = lines[i]
                    segments = Segment.apply_style(line.render(console), console.get_style(line.style))
                    marks = {j: mark for (k, j), mark in self.marks.get(cell, {}).items() if k == i}
                    yield from _with_marks(segments, marks) if marks else segments
                yield Segment.line()


def _darker(colour: str, factor: float) -> str:
    r, g, b = (int(colour[i : i + 2], 16) for i in (1, 3, 5))
    return "#{:02x}{:02x}{:02x}".format(*(round(v * factor) for v in (r, g, b)))


def _with_marks(segments, marks: Mapping[int, Mark]):
    chars = [Segment(ch, seg.style) for seg in segments for ch in seg.text]
    for j, (glyph, style) in marks.items():
        if 0 <= j < len(chars):
            chars[j] = Segment(glyph, chars[j].style + style)
    return Segment.simplify(chars)


def board_marks(world: World, cell_size: tuple[int, int], player: Cell | None, arrow: Arrow | None):
    """The glyphs of the player and its arrow, as `BoardGrid.marks`."""
    w, h = cell_size
    marks: dict[Cell, dict[tuple[int, int], Mark]] = {}

    def put(y: int, x: int, glyph: str, style: Style) -> None:
        if 0 <= y < world.rows * h and 0 <= x < world.cols * w:
            marks.setdefault((y // h, x // w), {})[(y % h, x % w)] = (glyph, style)

    if player is None:
        return marks
    cy, cx = player[0] * h + h // 2, player[1] * w + w // 2
    put(cy, cx, PLAYER_GLYPH, PLAYER_STYLE)
    if arrow is not None:
        dy, dx = OFFSETS[DIRECTIONS.index(arrow.direction)]
        n = arrow_length(arrow, cell_size)
        style = Style(color=level_colour(arrow.level, arrow.levels), bold=True)
        shafts = _SHAFTS[arrow.direction]
        shaft = shafts[min(len(shafts) - 1, int(_fraction(arrow) * len(shafts)))]
        for k in range(1, n + 1):
            put(cy + dy * k, cx + dx * k, _HEAD[arrow.direction] if k == n else shaft, style)
    return marks


class Board(Widget):
    """A world with the player, its arrow and highlighted cells.

    Args:
        world: the world to draw.
        values, scale, labels: passed to `WorldGrid` (a fitted reward, a policy's labels).

    Reactives:
        player: the player's cell, or None.
        arrow: the move being chosen, drawn from the player, or None.
        highlight: cells to frame in a colour (a slip), {cell: "#rrggbb"}; the player's cell is
            framed in `PLAYER_FRAME` unless highlighted.
    """

    player: reactive[Cell | None] = reactive(None)
    arrow: reactive[Arrow | None] = reactive(None)
    highlight: reactive[dict[Cell, str]] = reactive(dict)

    def __init__(
        self,
        world: World,
        *,
        values: np.ndarray | None = None,
        scale: float | None = None,
        labels: Mapping[Cell, str] | None = None,
        name: str | None = None,
        id: str | None = None,
        classes: str | None = None,
    ) -> None:
        super().__init__(name=name, id=id, classes=classes)
        self.world = world
        self.values = values
        self.scale = scale
        self.labels = dict(labels or {})

    def cell_size(self) -> tuple[int, int]:
        """(width, height) of a cell in characters, fitted to the widget's size (odd, to centre)."""
        rows, cols = self.world.rows, self.world.cols
        size = self.content_size
        w = min(MAX_CELL[0], max(MIN_CELL[0], size.width // cols))
        h = min(MAX_CELL[1], max(MIN_CELL[1], size.height // rows))
        # Keep cells about twice as wide as tall (a character is about twice as tall as wide).
        h = min(h, max(MIN_CELL[1], (w + 1) // 2))
        w = min(w, max(MIN_CELL[0], 2 * h + 5))
        return (w if w % 2 else w - 1), (h if h % 2 else h - 1)

    def grid(self) -> BoardGrid:
        """The renderable for the current state (also usable outside Textual)."""
        w, h = self.cell_size()
        frames = {} if self.player is None else {self.player: PLAYER_FRAME}
        return BoardGrid(
            self.world,
            values=self.values,
            scale=self.scale,
            labels=self.labels,
            highlight={**frames, **self.highlight},
            cell_width=w,
            cell_height=h,
            marks=board_marks(self.world, (w, h), self.player, self.arrow),
        )

    def render(self) -> BoardGrid:
        return self.grid()
