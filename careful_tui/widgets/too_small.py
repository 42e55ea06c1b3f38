"""The message a screen shows instead of itself when the terminal is too small for it."""

from __future__ import annotations

from rich.text import Text
from textual.widgets import Static


class TooSmall(Static):
    """Hidden until `check` finds the terminal smaller than needed; then the screen gets the
    `-too-small` class (its .tcss hides the rest) and this says how large to make it."""

    def check(self, width: int, height: int, need: tuple[int, int], *, command: str) -> bool:
        """Whether a `width` x `height` terminal is smaller than `need` (columns, rows)."""
        need_w, need_h = need
        too_small = width < need_w or height < need_h
        self.screen.set_class(too_small, "-too-small")
        if too_small:
            self.update(Text(f"The terminal is {width}x{height}; {command} needs {need_w}x{need_h}.\n"
                             "Make the window larger (q quits).", justify="center"))
        return too_small
