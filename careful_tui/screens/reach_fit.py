"""The fit view of a reach fit (docs/reach.md): `careful fit REACH.jsonl` in a terminal opens it.

It shows what `careful fit --no-view` prints, drawn: the field around its circles with every recorded endpoint
at sub-cell resolution and the best aims for the fitted and the world's points (`ReachField`), each symbol's
points with its interval on the reward colours' axis (`ReachIntervals`; a symbol bounded on one side shows its
bound, no point), the spread law, the player and the notes. The fit is made before the view opens (a reach
fit takes seconds, not minutes), so the view only draws; PageUp/PageDown scroll, `s` saves an SVG of the view,
q quits. The pictures are `careful_tui.render.reach_fit`'s; this module is layout and keys.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.screen import Screen
from textual.widgets import Static

from careful_tui.render.palette import NOTE
from careful_tui.render.reach_fit import ReachField, ReachIntervals, optima, reach_fit_title, spread_line
from careful_tui.widgets import KeyBar
from irl_core.errors import OutputError
from irl_core.reach.fit import ReachFit
from irl_core.recordings.writer import slug
from irl_core.support.safe_files import write_output
from irl_core.support.safe_text import printable

SCROLL = Binding.Group("scroll")


class ReachFitScreen(Screen[None]):
    """The drawn reach fit `fit` of the trials whose endpoints are `endpoints` (n, 2); `sources` the recordings
    (never written over by `s`)."""

    TITLE = "careful fit"
    BINDINGS = [
        Binding("s", "save_svg", "save SVG", priority=True),
        Binding("pageup", "scroll_body('up')", "scroll", key_display="PgUp", priority=True, group=SCROLL),
        Binding("pagedown", "scroll_body('down')", "scroll", key_display="PgDn", priority=True, group=SCROLL),
    ]

    def __init__(self, fit: ReachFit, endpoints: np.ndarray, *, sources: list[Path]) -> None:
        super().__init__()
        self.fit = fit
        self.endpoints = endpoints
        self.sources = sources
        self.saved: list[Path] = []

    def compose(self) -> ComposeResult:
        yield Static(Text(reach_fit_title(self.fit)), id="title")
        yield Static(id="status")
        with VerticalScroll(id="body"):
            field = Static(ReachField(self.fit, self.endpoints, optima(self.fit)), id="field")
            field.border_title = "endpoints and the best aims"
            yield field
            intervals = Static(ReachIntervals(self.fit), id="intervals")
            intervals.border_title = self._interval_title()
            yield intervals
            yield Static(self._lines(), id="notes")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        self.query_one("#body").focus()

    def _interval_title(self) -> str:
        if self.fit.interval_kind == "confidence":
            return f"each symbol's points: {self.fit.confidence:.0%} confidence intervals (Laplace)"
        return "each symbol's points: identified by the choices (every value they allow)"

    def _lines(self) -> Text:
        """The spread law, the player and every note, a line each."""
        fit = self.fit
        text = Text(spread_line(fit))
        if fit.beta is not None and fit.aim_sd is not None:
            text.append(f"\nplayer: soft-optimal, beta {fit.beta:.3g}, aim noise sd {fit.aim_sd:.3g}")
        for note in fit.notes:
            text.append(f"\nnote ({note.code}): {note.text}", style=NOTE)
        return text

    def action_scroll_body(self, direction: str) -> None:
        body = self.query_one("#body", VerticalScroll)
        (body.scroll_page_up if direction == "up" else body.scroll_page_down)()

    def action_save_svg(self) -> None:
        """Save the view as it looks as careful-fit-WORLD-reach.svg here (never over a recording)."""
        path = Path(f"careful-fit-{slug(self.fit.world.name)}-reach.svg")
        try:
            write_output(path, self.app.export_screenshot(title=reach_fit_title(self.fit)), option="s",
                         inputs=self.sources)
        except OutputError as exc:
            self.notify(printable(str(exc)), title="save SVG", severity="error", markup=False)
            return
        self.saved.append(path)
        self.query_one("#status", Static).update(Text(f"saved {printable(str(path))}"))
