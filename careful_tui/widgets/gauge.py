"""The carefulness gauge: one row per level, level L at the top, each level's cost beside it
(and, where given, the chance that a move of that level slips: goes another way than chosen).

It fills from the bottom while a key is held; `fill` is fractional so that the row being
reached fills smoothly (lower-block characters), and the level a move would get now is
marked, as is the level a calibration trial asks for (`target`, its number reversed). Play,
replay, the fit view and the calibration block share it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from rich.segment import Segment
from rich.style import Style
from textual.geometry import Region
from textual.reactive import reactive
from textual.strip import Strip
from textual.widget import Widget

from careful_tui.render.grid import format_chance, format_value
from careful_tui.render.palette import EMPTY, level_colour

_PARTIAL = " ▁▂▃▄▅▆▇█"
BAR_WIDTH = 6


class Gauge(Widget):
    """A vertical gauge of carefulness levels with their costs.

    Args:
        costs: the cost of each level 1..L, as positive numbers (shown negated: "-5").
        slips: the chance that a move of each level 1..L slips (0.5 is shown "50%"), or None
            for no such column.

    Reactives:
        fill: how far the gauge is filled, in levels: 0 is empty, 3.5 is levels 1-3 full and
            level 4 half full.
        level: the level a move would get now (marked), or None.
        target: the level asked for (a calibration trial's; its number shown reversed), or None.

    It draws line by line and repaints only the rows a change touches, so that filling it
    60 times a second stays cheap.
    """

    fill: reactive[float] = reactive(0.0, repaint=False)
    level: reactive[int | None] = reactive(None, repaint=False)
    target: reactive[int | None] = reactive(None, repaint=False)

    def __init__(self, costs: Sequence[float], *, slips: Sequence[float] | None = None, name: str | None = None,
                 id: str | None = None, classes: str | None = None) -> None:
        super().__init__(name=name, id=id, classes=classes)
        self.costs = list(costs)
        label_width = max(len(format_value(-cost)) for cost in self.costs)
        self._labels = [(format_value(-cost) if cost else "0").rjust(label_width) for cost in self.costs]
        if slips is not None:
            if len(slips) != len(self.costs):
                raise ValueError(f"{len(slips)} slip chances for {len(self.costs)} levels")
            chances = [format_chance(p) for p in slips]
            chance_width = max(len(chance) for chance in chances)
            self._labels = [f"{label} {chance.rjust(chance_width)}" for label, chance in zip(self._labels, chances)]
            label_width += 1 + chance_width
        self._number_width = len(str(self.levels))
        self._width = self._number_width + 1 + BAR_WIDTH + 1 + label_width + 2
        self._rows = [(0, False, False)] * self.levels

    @property
    def levels(self) -> int:
        return len(self.costs)

    def _row_state(self, c: int) -> tuple[int, bool, bool]:
        """(fill of level c's bar in eighths, is it the current level, is it the target)."""
        filled = min(1.0, max(0.0, self.fill - (c - 1)))
        return math.floor(filled * 8), c == self.level, c == self.target

    def _row_states(self) -> list[tuple[int, bool, bool]]:
        return [self._row_state(c) for c in range(self.levels, 0, -1)]

    def _watch_state(self) -> None:
        rows = self._row_states()
        changed = [Region(0, y, self._width, 1) for y, (a, b) in enumerate(zip(self._rows, rows)) if a != b]
        self._rows = rows
        if changed:
            self.refresh(*changed)

    watch_fill = watch_level = watch_target = _watch_state

    def render_line(self, y: int) -> Strip:
        if not 0 <= y < self.levels:
            return Strip.blank(self.content_size.width, self.visual_style.rich_style)
        c = self.levels - y
        eighths, current, target = self._rows[y]
        strip = _row_strip(c, self.levels, eighths, current, target, self._labels[c - 1], self._number_width)
        return strip.apply_style(self.rich_style)

    def get_content_width(self, container, viewport) -> int:
        return self._width

    def get_content_height(self, container, viewport, width: int) -> int:
        return self.levels


_STRIPS: dict[tuple, Strip] = {}


def _row_strip(c: int, levels: int, eighths: int, current: bool, target: bool, label: str,
               number_width: int) -> Strip:
    """One gauge row: level number (reversed for the target), bar, cost and the current-level marker (cached)."""
    key = (c, levels, eighths, current, target, label, number_width)
    strip = _STRIPS.get(key)
    if strip is None:
        colour = level_colour(c, levels)
        if eighths >= 8:
            bar = Segment(" " * BAR_WIDTH, Style(bgcolor=colour))
        elif eighths > 0:
            bar = Segment(_PARTIAL[eighths] * BAR_WIDTH, Style(color=colour, bgcolor=EMPTY))
        else:
            bar = Segment(" " * BAR_WIDTH, Style(bgcolor=EMPTY))
        number = [Segment(f"{c:>{number_width}}", Style(bold=True, reverse=True)), Segment(" ")] if target else \
            [Segment(f"{c:>{number_width}} ", Style(bold=True) if current else Style(dim=True))]
        strip = Strip([
            *number,
            bar,
            Segment(f" {label}", Style(color=colour, bold=current, dim=not current)),
            Segment(" ◀" if current else "  ", Style(color=colour, bold=True)),
        ])
        _STRIPS[key] = strip
    return strip
