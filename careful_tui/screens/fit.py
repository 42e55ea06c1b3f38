"""The fit view: a fitted reward as a picture, refitted with a key (docs/fitting.md and docs/index.md).

`careful fit FILE...` in a terminal opens it on the first fit (`careful_tui.commands.fit.run_fit`,
through `careful_tui.app.make_fit_app`).
It shows the fitted R_S coloured on the diverging log scale of `careful_tui.render.grid`, the
world's own R_S beside it on the same scale, how far the demonstrations pin each reward
(`IntervalChart` and a sentence per symbol), the demonstrated policy, the status and notes.

Keys switch the method (one per entry of `irl_core.irl.choices`: a for auto, l, o, m; tab cycles),
toggle the intervals (i), save an SVG of the view (s) and quit (q). A refit runs in a thread worker
while the last result stays on screen, dimmed, under a "fitting…" status; the thread posts
`FitScreen.Progress` while it works and hands back a `FitScreen.Fitted`. A newer request, or closing
the view, stops the fit that is running (`fit(stop=...)`), so only the latest is shown. A refit that
fails (an lp with no solution on noisy demonstrations, a solver that gives up) is reported in the
status line, in the command line's words (`careful_tui.option_words`), and the view keeps the last result.

The words and numbers drawn come from `careful_tui.render.fit_panels` (the body's panels),
`careful_tui.render.fit_printout` and `careful_tui.render.intervals` (shared with the printout), and the
boards are the shared `Board`; this module is layout and keys.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rich.text import Text
from textual import events, on, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Container, Horizontal, VerticalScroll
from textual.message import Message
from textual.reactive import var
from textual.screen import Screen
from textual.widgets import Static
from textual.worker import get_current_worker

import irl_core.irl.choices as choices
from careful_tui.option_words import said
from careful_tui.render.fit_panels import intervals_panel, notes_panel, policy_key, settings_line
from careful_tui.render.fit_printout import fit_page_svg, policy_labels, progress_phrase, reward_scale, status_text
from careful_tui.render.intervals import interval_title, scale_legend, shown_reward_grid
from careful_tui.render.palette import BAD, GOOD, NOTE, WARN
from careful_tui.render.session import legend
from careful_tui.widgets import Board, KeyBar
from careful_tui.widgets.board import MIN_CELL
from careful_tui.widgets.too_small import TooSmall
from irl_core.errors import OutputError
from irl_core.irl import FitError, FitOptions, FitResult, InfeasibleError, Stopped, fit
from irl_core.irl.choices import METHODS
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.recordings.writer import slug
from irl_core.support.plural import plural
from irl_core.support.safe_files import write_output
from irl_core.support.safe_text import printable

# Board cells in the fit view: 3 lines (symbol, value, label), 7 to this many characters wide.
CELL_HEIGHT = MIN_CELL[1]
MAX_CELL_WIDTH = 11
GAP = 2
POLICY_KEY_WIDTH = 34


def board_width(world_cols: int, room: int) -> int:
    """The outer width of a board (border included) in `room` columns: cells 7 to 11 wide, odd."""
    cell = min(MAX_CELL_WIDTH, max(MIN_CELL[0], (room - 2) // world_cols))
    return world_cols * (cell if cell % 2 else cell - 1) + 2


def error_message(error: Exception) -> str:
    """What a failed fit says in the view: the fit's own sentence (with the key to try next), or
    the unexpected exception."""
    if isinstance(error, InfeasibleError):
        return f"{said(error)}; press {METHODS['loss'].key} to fit with loss"
    if isinstance(error, FitError):
        return said(error)
    return f"unexpected error: {type(error).__name__}: {error} (please report it)"


SCROLL = Binding.Group("scroll")
SIDEWAYS = Binding.Group("sideways")
# The fit view opens from this many columns, whatever the world's width: its sentences wrap there, and a board
# wider than the terminal keeps its size while the body scrolls sideways.
MIN_VIEW_WIDTH = 60


def method_bindings(group: Binding.Group) -> list[Binding]:
    """A key per method (`irl_core.irl.choices`), in its order."""
    return [Binding(m.key, f"method('{m.name}')", m.name, priority=True, group=group) for m in METHODS.values()]


def default_svg_name(world: str, method: str, folder: Path) -> Path:
    """careful-fit-mud-lp.svg in `folder`, or -2, -3, ... when taken (a saved picture is never overwritten)."""
    stem = f"careful-fit-{slug(world, default='world')}-{method}"
    path, n = folder / f"{stem}.svg", 1
    while path.exists():
        n += 1
        path = folder / f"{stem}-{n}.svg"
    return path


class FitScreen(Screen[None]):
    """The fit view of one set of demonstrations (the CLI and the tests build its app with
    `careful_tui.app.make_fit_app`).

    Args:
        demos: the pooled demonstrations.
        options: the fit's settings; the keys change `method` and `intervals`.
        result: the fit of `options`, made before the view opened (the CLI's); without it the
            view fits at once in its worker.
        sources: the recordings' paths, for the title.
        svg: where `s` saves the picture, and where it is saved as soon as the first fit is
            drawn; without it `s` saves `careful-fit-WORLD-METHOD.svg` in the current folder.
        show_times: show the fit's seconds (snapshot tests turn it off: times vary).
    """

    @dataclass
    class Fitted(Message):
        """A fit has ended (sent from the fitting thread): its result, or the error it ended with."""

        request: int
        options: FitOptions
        result: FitResult | None
        error: Exception | None

    @dataclass
    class Progress(Message):
        """How far a fit has got (sent from the fitting thread): "round 3", "interval LP 12 of 62".

        Progress comes fast (a message per interval LP or resample); a newer one replaces one
        still queued, so the queue never backs up behind a long fit.
        """

        request: int
        phrase: str

        def can_replace(self, message: Message) -> bool:
            return isinstance(message, FitScreen.Progress) and message.request == self.request

    # What the view shows: the fit (compared by identity: its arrays have no single truth value),
    # its settings, the error of the last refit and the settings being fitted now. Their watchers
    # ask for one redraw after the next refresh, however many of them change at once (a fit's
    # end sets three); `set_reactive` in __init__ sets them before there is anything to draw.
    result: var[FitResult | None] = var(None, init=False, always_update=True)
    options: var[FitOptions] = var(FitOptions, init=False)
    error: var[str | None] = var(None, init=False)
    fitting: var[FitOptions | None] = var(None, init=False)

    TITLE = "careful fit"
    METHOD = Binding.Group("/".join(METHODS))
    BINDINGS = [
        *method_bindings(METHOD),
        Binding("tab", "next_method", "next method", priority=True, show=False),
        Binding("i", "toggle_intervals", "intervals", priority=True),
        Binding("s", "save_svg", "save SVG", priority=True),
        # The body scrolls with PageUp/PageDown (Textual's own); listed so the key bar says so.
        Binding("pageup", "scroll_body('up')", "scroll", key_display="PgUp", priority=True, group=SCROLL),
        Binding("pagedown", "scroll_body('down')", "scroll", key_display="PgDn", priority=True, group=SCROLL),
        # A world wider than the terminal scrolls sideways (shown only then, `check_action`).
        Binding("left", "scroll_body('left')", "sideways", key_display="←", priority=True, group=SIDEWAYS),
        Binding("right", "scroll_body('right')", "sideways", key_display="→", priority=True, group=SIDEWAYS),
    ]

    def __init__(
        self,
        demos: Demonstrations,
        options: FitOptions,
        *,
        result: FitResult | None = None,
        sources: Sequence[Path] = (),
        svg: Path | None = None,
        show_times: bool = True,
    ) -> None:
        super().__init__()
        self.demos = demos
        self.world = demos.mdp.world
        self.set_reactive(FitScreen.options, options)
        self.set_reactive(FitScreen.result, result)
        self.sources = list(sources)
        self.svg = svg
        self.show_times = show_times
        self.saved: list[Path] = []
        self._request = 0
        self._progress = ""
        self._save_first = svg is not None
        self._too_small = False
        self._too_wide = False
        self._failed_method = ""
        self._redraw_asked = False

    # ------------------------------------------------------------------ layout

    def compose(self) -> ComposeResult:
        yield Static(id="title")
        yield Static(id="status")
        with VerticalScroll(id="body"):
            yield Static(id="notes")
            with Container(id="rewards"):
                yield Board(self.world, id="fitted")
                true = Board(self.world, id="true")
                true.border_title = "true R_S (world file)"
                true.border_subtitle = legend(self.world)
                yield true
            yield Static(id="intervals")
            with Horizontal(id="policy-row"):
                policy = Board(self.world, id="policy")
                policy.border_title = "demonstrated policy"
                yield policy
                yield Static(id="policy-key")
        yield TooSmall(id="too-small")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        self.query_one("#true", Board).display = bool(self.world.rewards)
        policy = self.query_one("#policy", Board)
        self.query_one("#policy-key", Static).update(policy_key(self.world))
        self._layout(*self.app.size)
        self.query_one("#body").focus()
        if self.result is None:
            self._start(self.options)
        else:
            policy.labels = policy_labels(self.result)
            self.show()

    def on_resize(self, event: events.Resize) -> None:
        self._layout(event.size.width, event.size.height)

    def _layout(self, width: int, height: int) -> None:
        """Boards side by side when two fit, else stacked; the board sizes; the too-small check."""
        world = self.world
        smallest = board_width(world.cols, 0)
        self._too_small = self.query_one(TooSmall).check(width, height, (min(smallest + 4, MIN_VIEW_WIDTH), 12),
                                                         command="careful fit")
        room = width - 3  # the body's padding and scroll bar
        self._too_wide = room < smallest
        self.query_one("#body").set_class(self._too_wide, "-wide")
        two = bool(world.rewards) and room >= 2 * smallest + GAP
        each = board_width(world.cols, (room - GAP) // 2 if two else room)
        for board in self.query(Board):
            board.styles.width = each
            board.styles.height = world.rows * CELL_HEIGHT + 2
        self.query_one("#rewards").set_class(not two, "-stacked")
        self.query_one("#policy-row").set_class(room < each + GAP + POLICY_KEY_WIDTH, "-stacked")
        self.refresh_bindings()

    # ------------------------------------------------------------------ fitting

    def _start(self, options: FitOptions) -> None:
        """Fit with `options` in the worker; the answer to an earlier request is then ignored."""
        self._request += 1
        self._progress = ""
        self.error = None
        self.fitting = options
        self._fit(self._request, options)

    @work(thread=True, group="fit", exclusive=True)
    def _fit(self, request: int, options: FitOptions) -> None:
        # A newer request (exclusive) or the view closing cancels the worker, which stops the fit
        # (instead of minutes more on a big world's intervals, with the app waiting to exit).
        worker = get_current_worker()

        def post_progress(stage: str, done: int, total: int | None) -> None:
            self.post_message(FitScreen.Progress(request, progress_phrase(stage, done, total)))

        try:
            result, error = fit(self.demos, options, progress=post_progress, stop=lambda: worker.is_cancelled), None
        except Stopped:
            return
        except Exception as exc:  # noqa: BLE001 - a refit must not take the view down: the view says what happened
            result, error = None, exc
        self.post_message(FitScreen.Fitted(request, options, result, error))

    @on(Progress)
    def _progressed(self, message: Progress) -> None:
        if message.request == self._request and self.fitting is not None:
            self._progress = f": {message.phrase}"
            for status in self.query("#status").results(Static):  # none once the view is closing
                status.update(self._status())

    @on(Fitted)
    def _fitted(self, message: Fitted) -> None:
        if message.request != self._request:
            return
        self.fitting = None
        if message.result is None:
            # The view keeps the fit it shows, and its settings: the next key acts on that fit.
            self._failed_method = message.options.method
            assert message.error is not None, "a fit without a result ended with an error"
            self.error = error_message(message.error)
            self.notify(printable(self.error), title=f"{message.options.method} failed", severity="error", timeout=8,
                        markup=False)
        else:
            if not self.query_one("#policy", Board).labels:
                self.query_one("#policy", Board).labels = policy_labels(message.result)
            self.options = message.options
            self.result = message.result

    @property
    def busy(self) -> bool:
        return self.fitting is not None

    def action_method(self, method: str) -> None:
        """Refit with `method` (intervals as now); nothing to do if it is already shown."""
        shown = self.result is not None and self._asked_method() == method and self.error is None
        if (shown and not self.busy) or (self.fitting is not None and self.fitting.method == method):
            return
        self._start(dataclasses.replace(self._wanted(), method=choices.method(method).name))

    def action_next_method(self) -> None:
        """The next method in the keys' order (`irl_core.irl.choices.METHODS`), after the one asked for."""
        cycle = tuple(METHODS)
        self.action_method(cycle[(cycle.index(self._wanted().method) + 1) % len(cycle)])

    def action_scroll_body(self, direction: str) -> None:
        body = self.query_one("#body", VerticalScroll)
        {"up": body.scroll_page_up, "down": body.scroll_page_down, "left": body.scroll_page_left,
         "right": body.scroll_page_right}[direction]()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "scroll_body" and parameters and parameters[0] in ("left", "right"):
            return self._too_wide
        return True

    def action_toggle_intervals(self) -> None:
        """Show the intervals (computing them if the shown fit has none) or hide them."""
        wanted = dataclasses.replace(self._wanted(), intervals=not self._wanted().intervals)
        result = self.result
        computed = result is not None and self._asked_method() == wanted.method and result.intervals is not None
        if self.busy or (wanted.intervals and not computed):
            self._start(wanted)
            return
        self.options = wanted

    def _wanted(self) -> FitOptions:
        """The settings being fitted, else those of the view."""
        return self.fitting or self.options

    # ------------------------------------------------------------------ saving

    def action_save_svg(self) -> None:
        try:
            path = self.svg or default_svg_name(self.world.name, self._shown_method(), Path.cwd())
        except OSError as exc:  # the current folder was removed (or cannot be read) while the view was open
            self.notify(f"cannot save the SVG: the current folder is gone ({exc.strerror or exc}); "
                        "quit, cd to a folder that exists and fit again, or give --svg PATH",
                        title="save SVG", severity="error", markup=False)
            return
        self._save(path)

    def _save_first_svg(self) -> None:
        if not self._save_first:
            return
        self._save_first = False
        assert self.svg is not None, "_save_first is set only with --svg"
        self._save(self.svg)

    def _save(self, path: Path) -> None:
        try:
            # The whole fit, as `careful fit --svg` writes it: the screen shows only what is scrolled into sight.
            svg = (self.app.export_screenshot(title=self._svg_title()) if self.result is None else
                   fit_page_svg(self.demos, self.result, width=max(80, self.app.size.width), title=self._svg_title()))
            write_output(path, svg, option="--svg", inputs=self.sources)
        except OutputError as exc:
            self.notify(printable(str(exc)), title="save SVG", severity="error", markup=False)
            return
        self.saved.append(path)
        self.notify(f"saved {printable(str(path))}", title="save SVG", markup=False)

    def _svg_title(self) -> str:
        return f"careful fit: {self._shown_method()} on {printable(self.world.name, limit=80)}"

    def _shown_method(self) -> str:
        """The method of the shown fit (the one auto chose), else the options'."""
        return self.result.method if self.result is not None else self.options.method

    def _asked_method(self) -> str:
        """The method the shown fit was asked for (the chooser while its choice is shown)."""
        if self.result is None:
            return self.options.method
        asked = self.result.options.method
        return asked if METHODS[asked].chooser else self.result.method

    # ------------------------------------------------------------------ drawing

    def watch_result(self) -> None:
        self._ask_redraw()

    def watch_options(self) -> None:
        self._ask_redraw()

    def watch_error(self) -> None:
        self._ask_redraw()

    def watch_fitting(self) -> None:
        self._ask_redraw()

    def _ask_redraw(self) -> None:
        """`show` once after the next refresh, for every change asked for before it."""
        if not self._redraw_asked:
            self._redraw_asked = True
            self.call_after_refresh(self.show)

    def show(self) -> None:
        """Draw the current result, the busy state or error, and the keys (on mount, then once after
        the watchers' changes); the first fit drawn is saved as SVG when `svg` was given."""
        self._redraw_asked = False
        result = self.result
        self.query_one("#title", Static).update(self._title())
        self.query_one("#status", Static).update(self._status())
        self.query_one("#body").set_class(self.busy, "-busy")
        self.refresh_bindings()
        if result is None:
            return
        scale = reward_scale(result)
        fitted, true = self.query_one("#fitted", Board), self.query_one("#true", Board)
        fitted.border_title = f"fitted R_S · {result.method} point estimate"
        fitted.border_subtitle = scale_legend(scale)
        fitted.values, fitted.labels = shown_reward_grid(result)  # a bound, not a point, where one-sided
        fitted.scale = scale
        true.values, true.scale = result.true_reward_grid, scale
        true.border_subtitle = legend(self.world, scale=scale)  # its swatches in the colours its cells have
        for board in self.query(Board):
            board.redraw()
        self.query_one("#notes", Static).update(notes_panel(result))
        intervals = self.query_one("#intervals", Static)
        intervals.border_title = (interval_title(result) if self.options.intervals and result.intervals is not None
                                  else "how sure the fit is of each reward")
        intervals.update(intervals_panel(result, self.options))
        if self._save_first:
            # After the refresh that lays out what was just drawn.
            self.call_after_refresh(self._save_first_svg)

    def _title(self) -> Text:
        demos = self.demos
        method = self._shown_method()
        files = printable(self.sources[0].name, limit=80) if len(self.sources) == 1 else plural(demos.files, "file")
        return Text.assemble(
            ("careful fit", f"bold {NOTE}"), "  ", (method, "bold"), " on ", (printable(self.world.name, limit=80), "bold"),
            (f"  ·  {files}: {plural(demos.episodes, 'episode')}, {plural(demos.steps, 'step')}", "dim"),
            (f"  ·  {self._label(method)}" if self._label(method) else "", "dim"),
        )

    def _label(self, method: str) -> str:
        """What the paper calls the method, or for maxent with a model of people, that model."""
        result = self.result
        if result is not None and result.method == method and result.player_model not in (None, "boltzmann"):
            return f"{result.player_model} player model"
        return METHODS[method].label

    def _status(self) -> Text:
        if self.fitting is not None:
            return Text(f"⟳ fitting {self.fitting.describe()}…{self._progress}", style=f"bold {WARN}")
        if self.error is not None:
            shown = f" (showing {self.result.method})" if self.result is not None else ""
            return Text.assemble((f"✗ {self._failed_method}: ", f"bold {BAD}"), self.error, (shown, "dim"))
        if self.result is None:
            return Text()
        return Text.assemble(("✓ ", f"bold {GOOD}"), status_text(self.result, times=self.show_times, notes=False),
                             (f"   {settings_line(self.result)}", "dim"))
