"""The calibration screen: "hold an arrow for 2 seconds" measures the keyboard's autorepeat.

It feeds every arrow press and autorepeat to `careful_tui.keys.calibration.Calibration` and
ends the attempt at the key's release: a kitty release event, or a silence of `SILENCE_S` once
the autorepeat has started (`FIRST_REPEAT_S` before, longer than any initial delay it accepts).
It returns the calibrated `HoldProfile`, or None when cancelled.

Time: as in play, every key is timed by when it reached the app (`careful_tui.keys.arrival`),
so keys a stall of the event loop held back still measure the delay and period they showed;
the silence is the injectable `clock`'s time since the last key's arrival, on that clock. As in
play, the timer judges a silence only once the keys that came are handled
(`careful_tui.screens.behind_input`): after a stall, repeats still queued are no release.
"""

from __future__ import annotations

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static

from careful_tui.keys.arrival import KeyArrival
from careful_tui.keys.calibration import Calibration
from careful_tui.keys.hold import DIRECTIONS, Clock, HoldProfile
from careful_tui.keys.kitty import KeyRelease
from careful_tui.render.palette import BAR, EMPTY, GOOD, NOTE, ON_NOTE, SLIP
from careful_tui.screens.behind_input import TickBehindInput
from irl_core.words import plural

HOLD_S = 2.0
SILENCE_S = 0.3
FIRST_REPEAT_S = Calibration.DELAY_RANGE_MS[1] / 1000 + 0.2
BAR_WIDTH = 30
KEY_CHIP = f"bold {ON_NOTE} on {NOTE}"


class CalibrationScreen(TickBehindInput, ModalScreen[HoldProfile | None]):
    """Measure the autorepeat initial delay and period from one long hold of an arrow.

    `clock` and `event_times` are play's (`careful_tui.keys.arrival`).
    """

    def __init__(self, base: HoldProfile, *, clock: Clock, event_times: bool | None = None) -> None:
        super().__init__()
        self.base = base
        self.clock = clock
        self.arrival = KeyArrival(clock, event_times=event_times)
        self._calibration = Calibration(base)
        self._first: float | None = None
        self._last: float | None = None
        self._result: HoldProfile | None = None
        self._problem: str | None = None
        self._shown: tuple | None = None

    def compose(self) -> ComposeResult:
        with Vertical(id="calibration-box") as box:
            box.border_title = "calibrate"
            yield Static(id="calibration-text")

    def on_mount(self) -> None:
        self._ticker = self.set_interval(1 / 20, self._tick_behind_input)
        self._show()

    def on_key(self, event: events.Key) -> None:
        event.stop()
        event.prevent_default()
        key = event.key
        if key == "escape":
            self.dismiss(None)
        elif key == "enter" and self._result is not None:
            self.dismiss(self._result)
        elif key == "r":
            self._restart()
        elif key in DIRECTIONS and self._result is None and self._problem is None:
            came = self.arrival(event)
            if self._first is None:
                self._first = came
            self._last = came
            self._calibration.feed(key, came)
            self._show()

    def on_key_release(self, event: KeyRelease) -> None:
        event.stop()
        if event.key in DIRECTIONS and self._first is not None and self._result is None:
            self._finish()

    def tick(self, *, input_until: float | None = None) -> None:
        """End the attempt once the key has been released (silent by `input_until`, default now,
        with no key waiting to be handled); redraw the progress."""
        if self._last is not None and self._result is None and self._problem is None:
            silence = SILENCE_S if self._calibration.repeats else FIRST_REPEAT_S
            until = self.clock() if input_until is None else input_until
            if until - self._last >= silence and not self.input_waiting():
                self._finish()
            else:
                self._show()

    def _finish(self) -> None:
        try:
            self._result = self._calibration.result()
        except ValueError as exc:
            self._problem = str(exc)
        self._show()

    def _restart(self) -> None:
        self._calibration = Calibration(self.base)
        self._first = self._last = self._result = self._problem = None
        self._show()

    def _show(self) -> None:
        held = 0.0 if self._first is None else self.clock() - self._first
        state = (round(held, 1), self._calibration.repeats, self._result, self._problem)
        if state == self._shown:
            return
        self._shown = state
        text = Text()
        if self._result is not None:
            p = self._result
            text.append("Measured.\n\n", style=f"bold {GOOD}")
            text.append(f"Autorepeat starts after {p.initial_delay_ms:.0f} ms and repeats every "
                        f"{p.repeat_period_ms:.0f} ms.\nHolds under {p.initial_delay_ms:.0f} ms are level 1; "
                        f"every {p.ms_per_level:.0f} ms more adds a level.\nA tap (no autorepeat) is a move "
                        f"{p.first_repeat_timeout_ms:.0f} ms after the press.\n\n")
            text.append(" enter ", style=KEY_CHIP)
            text.append(" use it   ")
            text.append(" r ", style=KEY_CHIP)
            text.append(" again   ")
            text.append(" esc ", style=KEY_CHIP)
            text.append(" keep the current timing")
        elif self._problem is not None:
            text.append(f"{self._problem[0].upper()}{self._problem[1:]}.\n\n", style=f"bold {SLIP}")
            text.append(" r ", style=KEY_CHIP)
            text.append(" try again   ")
            text.append(" esc ", style=KEY_CHIP)
            text.append(" cancel")
        else:
            text.append("Hold any arrow key down for 2 seconds, then let go.\n\n", style="bold")
            filled = round(BAR_WIDTH * min(1.0, held / HOLD_S))
            text.append(" " * filled, style=f"on {BAR}")
            text.append(" " * (BAR_WIDTH - filled), style=f"on {EMPTY}")
            text.append(f"  {held:.1f} s   {plural(self._calibration.repeats, 'repeat')}\n\n")
            text.append("This measures your key repeat; levels count from it.\n\n", style="dim")
            text.append(" esc ", style=KEY_CHIP)
            text.append(" cancel")
        self.query_one("#calibration-text", Static).update(text)
