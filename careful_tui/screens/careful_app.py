"""What every careful app shares: the theme, the one stylesheet, the footer of keys, quitting.

`CAREFUL_THEME` registers `careful_tui.render.palette`'s colours as Textual theme variables, so
`careful.tcss` says `$good`, `$bad`, `$note`, `$warn`, `$busy`, `$slip`, `$ink`, `$frame` and
never a hex code. The play, replay and fit apps subclass `CarefulApp`; the stylesheet scopes
their differences by the app's type (`ReplayApp #gauge { ... }`). Each app lists its keys in
`BINDINGS` and hides those that do nothing now with `check_action`; the key bar
(`careful_tui.widgets.keybar`) shows them.
"""

from __future__ import annotations

from textual.app import App
from textual.binding import Binding
from textual.theme import Theme

from careful_tui.render.palette import BACKGROUND, BAD, FRAME, GOOD, INK, NOTE, PANEL, SLIP, SURFACE, WARN

CAREFUL_THEME = Theme(
    name="careful",
    primary=NOTE,
    foreground=INK,
    background=BACKGROUND,
    surface=SURFACE,
    panel=PANEL,
    success=GOOD,
    warning=WARN,
    error=BAD,
    dark=True,
    variables={
        "good": GOOD,
        "bad": BAD,
        "note": NOTE,
        "warn": WARN,
        "busy": WARN,
        "slip": SLIP,
        "ink": INK,
        "frame": FRAME,
    },
)


# Every app quits with q, Ctrl+C or Ctrl+Q (subclasses end their BINDINGS with these).
QUIT_BINDINGS = [
    Binding("q", "quit", "quit", priority=True),
    Binding("ctrl+c,ctrl+q", "quit", "quit", priority=True, show=False),
]


class CarefulApp(App[None]):
    """A careful app: the careful theme, `careful.tcss`, no command palette.

    Subclasses add their `BINDINGS`; `_too_small` is True while the terminal is smaller than
    the app needs (the screen's `TooSmall` says so, and the key bar then shows quitting only).
    """

    CSS_PATH = "careful.tcss"
    ENABLE_COMMAND_PALETTE = False
    def __init__(self, *, driver_class=None) -> None:
        super().__init__(driver_class=driver_class)
        self.register_theme(CAREFUL_THEME)
        self.theme = CAREFUL_THEME.name
        self._too_small = False
