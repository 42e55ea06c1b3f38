"""The board: a world drawn with `WorldGrid`, the player on it and the arrow of the move being
chosen, growing with the carefulness level. Play, replay and the fit view share it.

The cell size follows the space the widget gets: 7x3 characters at the least (an 80x24
terminal), up to 15x7; a board that has no room for 7x3 cells (a big world in a usual
terminal) gets smaller ones, down to 3x1.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from itertools import product

import numpy as np
from rich.console import Console
from rich.segment import Segment
from rich.style import Style
from textual.geometry import Region
from textual.reactive import reactive
from textual.strip import Strip
from textual.widget import Widget

from careful_tui.render.grid import WorldGrid
from careful_tui.render.palette import WHITE, level_colour
from irl_core.worlds.mdp import DIRECTIONS, OFFSETS
from irl_core.worlds.world import Cell, World

Mark = tuple[str, Style]

MIN_CELL = (7, 3)
# Where MIN_CELL cells do not fit, cells shrink down to these: a symbol between two spaces on one line, the
# arrow's length then told mostly by its colour and shaft (a 24x24 world needed 197x79 for its 7x3 cells).
SMALLEST_CELL = (3, 1)
MAX_CELL = (15, 7)
PLAYER_GLYPH = "●"
PLAYER_STYLE = Style(color=WHITE, bold=True)
PLAYER_FRAME = "#aab8c8"
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
    arrow can run from the player's cell into its neighbours.
    """

    marks: Mapping[Cell, Mapping[tuple[int, int], Mark]] = field(default_factory=dict)

    def background(self, cell: Cell) -> str:
        """The symbol's colour, a shade darker on every other cell so that cells can be counted."""
        colour = super().background(cell)
        if self.values is None and sum(cell) % 2:
            return _darker(colour, CHECKER_SHADE)
        return colour

    def cell_segments(self, cell: Cell, console: Console) -> list[list[Segment]]:
        """The cell's `cell_height` lines as segments, its marks drawn in."""
        marks = self.marks.get(cell, {})
        lines = super().cell_segments(cell, console)
        for i, segments in enumerate(lines):
            on_line = {j: mark for (k, j), mark in marks.items() if k == i}
            if on_line:
                lines[i] = _with_marks(segments, on_line)
        return lines


def _darker(colour: str, factor: float) -> str:
    r, g, b = (int(colour[i : i + 2], 16) for i in (1, 3, 5))
    return "#{:02x}{:02x}{:02x}".format(*(round(v * factor) for v in (r, g, b)))


def _with_marks(segments, marks: Mapping[int, Mark]):
    chars = [Segment(ch, seg.style) for seg in segments for ch in seg.text]
    for j, (glyph, style) in marks.items():
        if 0 <= j < len(chars):
            chars[j] = Segment(glyph, (chars[j].style or Style.null()) + style)
    return list(Segment.simplify(chars))


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
        style = Style(color=level_colour(math.floor(arrow.level), arrow.levels), bold=True)
        shafts = _SHAFTS[arrow.direction]
        shaft = shafts[min(len(shafts) - 1, int(_fraction(arrow) * len(shafts)))]
        for k in range(1, n + 1):
            put(cy + dy * k, cx + dx * k, _HEAD[arrow.direction] if k == n else shaft, style)
    return marks


class Board(Widget):
    """A world with the player, its arrow and highlighted cells, centred in the widget.

    Args:
        world: the world to draw.
        values, scale, labels: passed to `WorldGrid` (a fitted reward, a policy's labels).

    Reactives:
        player: the player's cell, or None.
        arrow: the move being chosen, drawn from the player, or None.
        highlight: cells to frame in a colour (a slip), {cell: "#rrggbb"}; the player's cell is
            framed in `PLAYER_FRAME` unless highlighted.

    It draws line by line (Textual's line API) from cells it caches: a change of the player or
    the arrow redraws only the cells they touch, which keeps a held key's redraw cheap.
    """

    player: reactive[Cell | None] = reactive(None, repaint=False)
    arrow: reactive[Arrow | None] = reactive(None, repaint=False)
    highlight: reactive[dict[Cell, str]] = reactive(dict, repaint=False)

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
        self._cells: dict[tuple, list[list[Segment]]] = {}
        self._lines: list[list[Segment]] | None = None

    def cell_size(self) -> tuple[int, int]:
        """(width, height) of a cell in characters, fitted to the widget's size (odd, to centre)."""
        rows, cols = self.world.rows, self.world.cols
        size = self.content_size
        room_w, room_h = size.width // cols, size.height // rows
        if room_w < MIN_CELL[0] or room_h < MIN_CELL[1]:
            w = max(SMALLEST_CELL[0], min(room_w, MIN_CELL[0]))
            h = max(SMALLEST_CELL[1], min(room_h, MIN_CELL[1], (w + 1) // 2))
            return (w if w % 2 else w - 1), (h if h % 2 else h - 1)
        w = min(MAX_CELL[0], max(MIN_CELL[0], size.width // cols))
        h = min(MAX_CELL[1], max(MIN_CELL[1], size.height // rows))
        # Keep cells about twice as wide as tall (a character is about twice as tall as wide).
        h = min(h, max(MIN_CELL[1], (w + 1) // 2))
        w = min(w, max(MIN_CELL[0], 2 * h + 5))
        return (w if w % 2 else w - 1), (h if h % 2 else h - 1)

    def grid(self) -> BoardGrid:
        """The board as a Rich renderable in its current state (for printing or SVG export)."""
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

    def _watch_state(self) -> None:
        """Repaint only the lines that changed."""
        old, self._lines = self._lines, None
        if not self.is_mounted:
            return
        new = self._board_lines()
        if old is None or len(old) != len(new):
            self.refresh()
            return
        top = self._top()
        width = self.content_size.width
        changed = [Region(0, top + y, width, 1) for y, (a, b) in enumerate(zip(old, new)) if a != b]
        if changed:
            self.refresh(*changed)

    def _top(self) -> int:
        return max(0, (self.content_size.height - self.world.rows * self.cell_size()[1]) // 2)

    watch_player = watch_arrow = watch_highlight = _watch_state

    def redraw(self) -> None:
        """Draw everything again, e.g. after changing `values`, `scale` or `labels`."""
        self._cells.clear()
        self._lines = None
        self.refresh()

    def on_resize(self) -> None:
        self.redraw()

    def _board_lines(self) -> list[list[Segment]]:
        if self._lines is None:
            grid = self.grid()
            console = self.app.console
            if len(self._cells) > 2000:
                self._cells.clear()
            cells = {}
            for cell in product(range(grid.world.rows), range(grid.world.cols)):
                marks = grid.marks.get(cell)
                key = (cell, grid.cell_width, grid.cell_height, grid.highlight.get(cell),
                       tuple(sorted(marks.items())) if marks else None)
                if key not in self._cells:
                    self._cells[key] = grid.cell_segments(cell, console)
                cells[cell] = self._cells[key]
            self._lines = [
                [segment for c in range(grid.world.cols) for segment in cells[(r, c)][i]]
                for r in range(grid.world.rows)
                for i in range(grid.cell_height)
            ]
        return self._lines

    def render_line(self, y: int) -> Strip:
        width, height = self.content_size
        background = self.visual_style.rich_style
        lines = self._board_lines()
        board_width = self.world.cols * self.cell_size()[0]
        top = self._top()
        left = max(0, (width - board_width) // 2)
        if not top <= y < top + len(lines):
            return Strip.blank(width, background)
        right = max(0, width - left - board_width)
        segments = [Segment(" " * left, background), *lines[y - top], Segment(" " * right, background)]
        return Strip(segments).crop(0, width)
