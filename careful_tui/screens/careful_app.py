"""The one careful app: the theme, the one stylesheet, the terminal driver, quitting.

`CAREFUL_THEME` registers `careful_tui.render.palette`'s colours as Textual theme variables, so
`careful.tcss` says `$good`, `$bad`, `$note`, `$warn`, `$busy`, `$slip`, `$ink`, `$frame` and
never a hex code. Play, replay and the fit view are `Screen`s of one `CarefulApp`, which opens
on the screen it is given (`careful_tui.app` chooses it) and can push more; the stylesheet
scopes their differences by the screen's type (`ReplayScreen #gauge { ... }`). Each screen
lists its keys in `BINDINGS` and hides those that do nothing now with `check_action`; the app
adds the quit keys; the key bar (`careful_tui.widgets.keybar`) shows them.
"""

from __future__ import annotations

from textual.app import App
from textual.binding import Binding
from textual.screen import Screen
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


# The app quits with q, Ctrl+C or Ctrl+Q, whatever screen is on top (a screen that must save
# something as it goes, as play records the running episode, does it when it is unmounted).
QUIT_BINDINGS = [
    Binding("q", "quit", "quit", priority=True),
    Binding("ctrl+c,ctrl+q", "quit", "quit", priority=True, show=False),
]


class CarefulApp(App[None]):
    """The careful app: the careful theme, `careful.tcss`, no command palette, opening on `first_screen`.

    Args:
        first_screen: the screen it opens on (play, replay or the fit view); it stays reachable
            as `first_screen` while other screens are pushed over it.
        driver_class: the terminal driver (the CLI passes the kitty driver).
    """

    CSS_PATH = "careful.tcss"
    ENABLE_COMMAND_PALETTE = False
    BINDINGS = QUIT_BINDINGS

    def __init__(self, first_screen: Screen, *, driver_class=None) -> None:
        super().__init__(driver_class=driver_class)
        self.register_theme(CAREFUL_THEME)
        self.theme = CAREFUL_THEME.name
        self.first_screen = first_screen
        self.title = first_screen.TITLE or self.title

    def get_default_screen(self) -> Screen:
        return self.first_screen
