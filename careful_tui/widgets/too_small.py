"""The message a screen shows instead of itself when the terminal is too small for it, and the
one thing every screen does when the terminal is resized.

Every screen calls `TooSmall.check` from its `on_resize` with the event's size, which is the size
Textual lays the screen out at just after (deciding from `App.size` instead can set the class for
a size the screen is not laid out at). `check` also has the whole screen repainted: Textual lets
a storm of resizes through as the last size only, which can be the size the screen is already
laid out at; its layout then finds nothing changed and repaints nothing, while the terminal has
cropped what it showed to the storm's smallest size. The screen stayed blank but for its title
until the next resize (about 1 run in 4 of the tmux resize test).
"""

from __future__ import annotations

from rich.text import Text
from textual.widgets import Static


class TooSmall(Static):
    """Hidden until `check` finds the terminal smaller than needed; then the screen gets the
    `-too-small` class (its .tcss hides the rest) and this says how large to make it, and any
    `tell` note (play: the move being entered was cancelled) until the terminal is large enough."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._need = ""
        self._note = ""

    def check(self, width: int, height: int, need: tuple[int, int], *, command: str) -> bool:
        """Whether a `width` x `height` terminal is smaller than `need` (columns, rows); the screen
        is then repainted whole, whether or not its layout changes."""
        need_w, need_h = need
        too_small = width < need_w or height < need_h
        self.screen.set_class(too_small, "-too-small")
        if too_small:
            self._need = (f"The terminal is {width}x{height}; {command} needs {need_w}x{need_h}.\n"
                          "Make the window larger (q quits).")
            self._show()
        else:
            self._note = ""
        self.screen.refresh()
        return too_small

    def tell(self, note: str) -> None:
        """Add `note` under the message while the terminal stays too small."""
        self._note = note
        self._show()

    def _show(self) -> None:
        self.update(Text("\n\n".join(filter(None, (self._need, self._note))), justify="center"))
