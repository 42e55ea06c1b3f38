"""`careful play` on a reach world: the reach session (`irl_core.play.reach_session`) in a terminal (docs/reach.md).

The arrow keys move the aim marker over the field (shift moves it four times as far); holding space (or
Enter) times the reach, and a ring around the aim shows the endpoint's spread for the hold so far, shrinking
while the key is held (white within the world's limits, yellow while still too quick, red once too slow);
letting go launches it. The session keeps every rule: the refusals, the endpoint, the score and the
recording. This screen turns Textual's key events into its calls and draws its `view()`: the field, and a
panel with the trial, the score, the hold and the line for the participant.

Keys are timed as in play (`careful_tui.keys.arrival`): kitty releases when the terminal sends them, else the
silence after the last autorepeat, judged behind the keys already read (`TickBehindInput`); a 30 Hz timer
runs while a reach is being timed. A window too small for the field cancels a reach being timed and says so.
"""

from __future__ import annotations

import asyncio
import os
import signal

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal
from textual.screen import Screen
from textual.widgets import Static

from careful_tui.keys.arrival import KeyArrival
from careful_tui.keys.kitty import KeyRelease, key_repeat
from careful_tui.render.palette import BAD, GOOD, NOTE, WARN
from careful_tui.render.reach_field import FieldMarks, field_legend
from careful_tui.screens.behind_input import TickBehindInput
from careful_tui.screens.play import message_text
from careful_tui.widgets import KeyBar
from careful_tui.widgets.reach_field import ReachField
from careful_tui.widgets.too_small import TooSmall
from irl_core.play.reach_session import REACH_INTRO, ReachSession, ReachView
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable

TICK_S = 1 / 30
# The panel beside the field, and the smallest terminal: a field of 40 columns (15 rows) beside it.
PANEL_WIDTH = 30
MINIMUM_SIZE = (74, 20)
AIM_KEYS = {"left": (-1, 0), "right": (1, 0), "up": (0, -1), "down": (0, 1)}
FAST_AIM = 4
WITHIN_WORDS = {"ok": ("", GOOD), "short": (" (too quick yet)", WARN), "long": (" (too slow: let go)", BAD)}


class ReachScreen(TickBehindInput, Screen[None]):
    """The play screen of one `ReachSession`. Build its app with `careful_tui.app.make_reach_app`.

    `event_times` says whether key events' own times are on the session's clock (as `PlayScreen`'s)."""

    TITLE = "careful play"
    BINDINGS = [
        Binding("left,right,up,down", "aim", "aim", key_display="←→↑↓"),
        Binding("shift+left,shift+right,shift+up,shift+down", "aim", "aim faster", key_display="shift"),
        Binding("space,enter", "reach", "hold, let go: reach", key_display="space"),
    ]

    def __init__(self, session: ReachSession, *, event_times: bool | None = None) -> None:
        super().__init__()
        self.session = session
        self.world = session.world
        self.clock = session.clock
        self.arrival = KeyArrival(session.clock, event_times=event_times)
        self._done_shown: bool | None = None

    def compose(self) -> ComposeResult:
        yield Static(id="title")
        with Horizontal(id="main"):
            field = ReachField(self.world, self._marks(self.session.view()), id="reach-field")
            field.border_title = Text(f"{printable(self.world.name, limit=40)} · "
                                      f"{self.world.min_ms:g} to {self.world.max_ms:g} ms")
            field.border_subtitle = field_legend(self.world)
            yield field
            yield Static(id="reach-panel")
        yield TooSmall(id="too-small")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        self._ticker = self.set_interval(TICK_S, self._tick_behind_input, pause=True)
        self._check_size(*self.app.size)
        self._show()
        if not self.app.is_headless:
            loop = asyncio.get_running_loop()
            loop.add_signal_handler(signal.SIGHUP, self.hang_up)
            loop.add_signal_handler(signal.SIGTERM, self.app.exit)

    def on_unmount(self) -> None:
        self.session.quit()

    def on_resize(self, event: events.Resize) -> None:
        self._check_size(event.size.width, event.size.height)

    def _check_size(self, width: int, height: int) -> None:
        command = self.session.options.command
        if self.query_one(TooSmall).check(width, height, MINIMUM_SIZE, command=command):
            if self.session.cancel_hold("window too small"):
                self.query_one(TooSmall).tell("The reach being timed was cancelled.")
                self._show()

    # ------------------------------------------------------------------ input

    def on_key(self, event: events.Key) -> None:
        key, session = event.key, self.session
        if self.has_class("-too-small"):
            return
        if key in session.keys and not session.done:
            event.stop()
            event.prevent_default()
            session.press(key, repeat=key_repeat(event), at=self.arrival(event))
            if session.entering():
                self._ticker.resume()
        elif key.removeprefix("shift+") in AIM_KEYS and not session.done:
            event.stop()
            event.prevent_default()
            dx, dy = AIM_KEYS[key.removeprefix("shift+")]
            step = session.aim_step * (FAST_AIM if key.startswith("shift+") else 1)
            session.move_aim(dx * step, dy * step)
        self._show()

    def on_key_release(self, event: KeyRelease) -> None:
        if event.key in self.session.keys:
            self.session.release(event.key, at=self.arrival(event))
            self._show()

    def tick(self, *, input_until: float | None = None) -> None:
        """Launch a reach whose autorepeats fell silent by `input_until` (no key waiting to be handled), and
        redraw the ring; tests call it after moving a fake clock."""
        self.session.tick(until=input_until, keys_waiting=self.input_waiting())
        if not self.session.entering():
            self._ticker.pause()
        self._show()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action in ("aim", "reach"):
            return not self.session.done
        return super().check_action(action, parameters)

    def action_aim(self) -> None:
        """Nothing: `on_key` reads the keys (these bindings only name them in the key bar)."""

    action_reach = action_aim

    def hang_up(self) -> None:
        """The terminal was closed: close the file (each trial is already on disk) and leave at once, as play does."""
        self.session.quit()
        os._exit(128 + signal.SIGHUP)

    # ------------------------------------------------------------------ drawing

    @staticmethod
    def _marks(view: ReachView) -> FieldMarks:
        holding = view.holding
        return FieldMarks(aim=view.aim, ring_sd=None if holding is None else holding.ring_sd,
                          within="ok" if holding is None else holding.within,
                          endpoint=None if view.last is None else view.last.endpoint)

    def _show(self) -> None:
        view = self.session.view()
        if view.done != self._done_shown:
            self._done_shown = view.done
            self.refresh_bindings()
        self.query_one(ReachField).marks = self._marks(view)
        self.query_one("#reach-panel", Static).update(panel_text(view, self.session))
        self.query_one("#title", Static).update(Text.assemble(
            (printable(self.session.options.heading, limit=60), f"bold {NOTE}"),
            " · player ", (printable(self.session.options.player, limit=40), "bold"), " · reach",
            (f" · recording → {printable(view.recording, limit=200)}", "dim")), layout=False)


def panel_text(view: ReachView, session: ReachSession) -> Text:
    """The panel beside the field: the trial and the score, the hold being timed, the line for the participant,
    and how to play."""
    world = view.world
    text = Text()
    if view.done:
        done = "Block done." if session.write_error is None else "Stopped: the trial could not be written."
        text.append(f"{done}\n", style=f"bold {GOOD if session.write_error is None else BAD}")
        text.append(f"{plural(len(session.steps), 'trial')} · score {view.score:.1f}\n\n")
        text.append_text(message_text(view.message))
        text.append("\n\n")
        # Not space: a held key's last autorepeats would leave before the result is seen.
        text.append("q leaves.", style="dim")
        return text
    text.append(f"Trial {view.trial} of {view.trials}\n", style=f"bold {NOTE}")
    text.append(f"Score {view.score:.1f}\n\n")
    if view.holding is not None:
        words, style = WITHIN_WORDS[view.holding.within]
        text.append(f"Holding {view.holding.held_ms:.0f} ms{words}\n", style=f"bold {style}")
        text.append(f"ring: sd {view.holding.ring_sd:.1f}\n")
    else:
        text.append(f"Aim ({view.aim[0]:.0f}, {view.aim[1]:.0f})\n", style="bold")
        text.append(f"{world.cost_per_second:g} points a second\n")
    text.append("\n")
    text.append_text(message_text(view.message))
    text.append("\n\n")
    text.append(REACH_INTRO, style="dim")
    return text
