"""The keys that do something now, on one line at the bottom of every screen.

The keys come from the app's and the screen's `BINDINGS`, as `check_action` allows them now
(`Screen.active_bindings`): no screen lists its keys by hand. Bindings in one `Binding.Group`
share a chip ("a/l/o/m auto/lp/loss/maxent"). It plays the part of Textual's `Footer`, but draws
in the very first frame (the Footer composes its keys only after a refresh, which a terminal
test reading the first frame sees as a missing key bar) and keeps the chip look of careful.

When the chips do not fit the terminal's width they close up (no padding in the chip, one space
between), and if that is still too wide the last chips give way, quitting's never: `q quit` is on
screen at every size a screen accepts.
"""

from __future__ import annotations

from rich.cells import cell_len
from rich.text import Text
from textual.binding import Binding
from textual.screen import ActiveBinding
from textual.widget import Widget

from careful_tui.render.palette import NOTE, ON_NOTE


def joined(keys: list[str]) -> str:
    """Keys of one chip: arrows run together ("←→"), letters take slashes ("a/l"), words spaces."""
    if all(len(key) == 1 for key in keys):
        return ("/" if all(key.isalnum() for key in keys) else "").join(keys)
    return " ".join(keys)


class KeyBar(Widget):
    """The active bindings as chips: a key, then what it does."""

    def on_mount(self) -> None:
        self.screen.bindings_updated_signal.subscribe(self, lambda _screen: self.refresh())

    @property
    def keys(self) -> tuple[tuple[str, str], ...]:
        """(keys, what they do) per chip, in the order of `BINDINGS`; only quitting while the
        screen is too small (`TooSmall` hides everything else)."""
        return tuple((keys, what) for keys, what, _ in self._chips())

    def _chips(self) -> list[tuple[str, str, bool]]:
        """(keys, what they do, whether they quit) per chip."""
        too_small = self.screen.has_class("-too-small")
        # Several keys of one binding (or one action and text) make one chip.
        first_of_action: dict[tuple[str, str], Binding] = {}
        for active in self._in_declared_order():
            binding = active.binding
            if binding.show and active.enabled and (binding.action == "quit" or not too_small):
                first_of_action.setdefault((binding.action, binding.description), binding)
        chips: dict[object, tuple[list[str], str, bool]] = {}
        for binding in first_of_action.values():
            shown = binding.key_display or self.app.get_key_display(binding)
            if binding.group is None:
                chips[binding] = ([shown], binding.description, binding.action == "quit")
            else:
                chips.setdefault(binding.group, ([], binding.group.description, False))[0].append(shown)
        return [(joined(keys), what, quits) for keys, what, quits in chips.values()]

    def _in_declared_order(self) -> list[ActiveBinding]:
        """The active bindings, the screen's then the app's then the rest, each node's in the order of
        its `BINDINGS`. Textual orders them by the focused widget's keys first, so a screen's
        priority binding for a key the focused widget also binds (PageDown on a scroll) jumped ahead."""
        nodes: list[object] = [self.screen, self.app]

        def place(active: ActiveBinding) -> tuple[int, int]:
            rank = nodes.index(active.node) if active.node in nodes else len(nodes)
            declared = [binding for _, binding in active.node._bindings]
            return rank, declared.index(active.binding) if active.binding in declared else len(declared)

        return sorted(self.screen.active_bindings.values(), key=place)

    def render(self) -> Text:
        chips, width = self._chips(), self.size.width
        bar = _bar(chips, roomy=True)
        if width and _width(bar) > width:  # closed up, then without the last chips that do not quit
            bar = _bar(chips, roomy=False)
            while _width(bar) > width and not all(quits for *_, quits in chips):
                del chips[max(i for i, (*_, quits) in enumerate(chips) if not quits)]
                bar = _bar(chips, roomy=False)
        if width and bar.cell_len > width:
            bar.rstrip()  # its last gap, which would be cut with an ellipsis
        return bar


def _bar(chips: list[tuple[str, str, bool]], *, roomy: bool) -> Text:
    """The chips on one line: `roomy` pads each key and leaves two spaces after its words."""
    pad, gap = (" ", "  ") if roomy else ("", " ")
    text = Text(no_wrap=True, overflow="ellipsis")
    for key, action, _ in chips:
        text.append(f"{pad}{key}{pad}", style=f"bold {ON_NOTE} on {NOTE}")
        text.append(f" {action}{gap}")
    return text


def _width(bar: Text) -> int:
    """The columns `bar` needs: its last gap may be cut."""
    return cell_len(bar.plain.rstrip())
