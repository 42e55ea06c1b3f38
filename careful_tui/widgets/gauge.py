"""The carefulness gauge: one row per level, level L at the top, each level's cost beside it.

It fills from the bottom while a key is held; `fill` is fractional so that the row being
reached fills smoothly (lower-block characters), and the level a move would get now is
marked. Play, replay and the fit view share it.
"""

from __future__ import annotations

from collections.abc import Sequence

from rich.style import Style
from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from careful_tui.grid import format_value

# Level colours run from cheap and risky (cool) to careful and costly (warm).
_COLOUR_STOPS = ((0x4F, 0xC3, 0xF7), (0xFF, 0xD5, 0x4F), (0xFF, 0x5A, 0x36))
EMPTY = "#262b33"
_PARTIAL = " ▁▂▃▄▅▆▇█"
BAR_WIDTH = 6


def level_colour(level: float, levels: int) -> str:
    """The colour of carefulness `level` (1..levels, may be fractional) as #rrggbb."""
    f = 0.0 if levels <= 1 else min(1.0, max(0.0, (level - 1) / (levels - 1)))
    x = f * (len(_COLOUR_STOPS) - 1)
    i = min(int(x), len(_COLOUR_STOPS) - 2)
    a, b = _COLOUR_STOPS[i], _COLOUR_STOPS[i + 1]
    t = x - i
    return "#{:02x}{:02x}{:02x}".format(*(round(p + (q - p) * t) for p, q in zip(a, b)))


class Gauge(Widget):
    """A vertical gauge of carefulness levels with their costs.

    Args:
        costs: the cost of each level 1..L, as positive numbers (shown negated: "-5").

    Reactives:
        fill: how far the gauge is filled, in levels: 0 is empty, 3.5 is levels 1-3 full and
            level 4 half full.
        level: the level a move would get now (marked), or None.
    """

    fill: reactive[float] = reactive(0.0)
    level: reactive[int | None] = reactive(None)

    def __init__(self, costs: Sequence[float], *, name: str | None = None, id: str | None = None,
                 classes: str | None = None) -> None:
        super().__init__(name=name, id=id, classes=classes)
        self.costs = list(costs)
        self._labels = [format_value(-cost) if cost else "0" for cost in self.costs]

    @property
    def levels(self) -> int:
        return len(self.costs)

    def render(self) -> Text:
        levels = self.levels
        number_width = len(str(levels))
        label_width = max(len(label) for label in self._labels)
        text = Text(no_wrap=True, overflow="crop")
        for c in range(levels, 0, -1):
            colour = level_colour(c, levels)
            current = c == self.level
            text.append(f"{c:>{number_width}} ", style="bold" if current else "dim")
            filled = self.fill - (c - 1)
            if filled >= 1:
                text.append(" " * BAR_WIDTH, style=Style(bgcolor=colour))
            elif filled > 0:
                block = _PARTIAL[max(1, int(filled * (len(_PARTIAL) - 1)))]
                text.append(block * BAR_WIDTH, style=Style(color=colour, bgcolor=EMPTY))
            else:
                text.append(" " * BAR_WIDTH, style=Style(bgcolor=EMPTY))
            label = self._labels[c - 1].rjust(label_width)
            text.append(f" {label}", style=Style(color=colour, bold=True) if current else Style(color=colour, dim=True))
            text.append(" ◀" if current else "  ", style=Style(color=colour, bold=True))
            if c > 1:
                text.append("\n")
        return text

    def get_content_width(self, container, viewport) -> int:
        return len(str(self.levels)) + 1 + BAR_WIDTH + 1 + max(len(s) for s in self._labels) + 2

    def get_content_height(self, container, viewport, width: int) -> int:
        return self.levels
