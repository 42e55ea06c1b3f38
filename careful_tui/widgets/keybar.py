"""A one-line bar of keys and what they do, for the keys of the current mode."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from careful_tui.render.palette import NOTE, ON_NOTE


class KeyBar(Widget):
    """Shows `keys`, a sequence of (key label, what it does), as chips on one line."""

    keys: reactive[tuple[tuple[str, str], ...]] = reactive(tuple)

    def show(self, keys: Sequence[tuple[str, str]]) -> None:
        self.keys = tuple(keys)

    def render(self) -> Text:
        text = Text(no_wrap=True, overflow="ellipsis")
        for key, action in self.keys:
            text.append(f" {key} ", style=f"bold {ON_NOTE} on {NOTE}")
            text.append(f" {action}  ")
        return text
