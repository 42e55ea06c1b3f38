"""The calibration screen: "hold an arrow for 2 seconds" measures the keyboard's autorepeat.

It draws one `irl_core.play.calibration.Calibrating` attempt (the session's `start_calibration`)
and feeds it every arrow press, autorepeat and release; the attempt ends at the key's release
(a kitty release event, or the silence after the last key). Escape cancels, `r` tries again,
Enter takes the result. It returns the calibrated `HoldProfile`, or None when cancelled.

Time: as in play, every key is timed by when it reached the app (`careful_tui.keys.arrival`),
so keys a stall of the event loop held back still measure the delay and period they showed;
the silence is judged on the session's clock. As in play, the timer judges a silence only once
the keys that came are handled (`careful_tui.screens.behind_input`): after a stall, repeats
still queued are no release.
"""

from __future__ import annotations

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static

from careful_tui.keys.arrival import KeyArrival
from careful_tui.keys.kitty import KeyRelease
from careful_tui.render.palette import BAR, EMPTY, GOOD, NOTE, ON_NOTE, SLIP
from careful_tui.screens.behind_input import TickBehindInput
from irl_core.play.calibration import HOLD_S, Calibrating
from irl_core.play.hold import HoldProfile
from irl_core.support.plural import plural

BAR_WIDTH = 30
KEY_CHIP = f"bold {ON_NOTE} on {NOTE}"


class CalibrationScreen(TickBehindInput, ModalScreen[HoldProfile | None]):
    """Measure the autorepeat initial delay and period from one long hold of an arrow.

    `event_times` is play's (`careful_tui.keys.arrival`).
    """

    def __init__(self, calibrating: Calibrating, *, event_times: bool | None = None) -> None:
        super().__init__()
        self.calibrating = calibrating
        self.clock = calibrating.clock
        self.arrival = KeyArrival(calibrating.clock, event_times=event_times)
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
        key, calibrating = event.key, self.calibrating
        if key == "escape":
            self.dismiss(None)
        elif key == "enter" and calibrating.result is not None:
            self.dismiss(calibrating.result)
        elif key == "r":
            calibrating.restart()
            self._show()
        else:
            calibrating.press(key, at=self.arrival(event))
            self._show()

    def on_key_release(self, event: KeyRelease) -> None:
        event.stop()
        self.calibrating.release(event.key)
        self._show()

    def tick(self, *, input_until: float | None = None) -> None:
        """End the attempt once the key has been released (silent by `input_until`, default now,
        with no key waiting to be handled); redraw the progress."""
        if self.calibrating.measuring:
            self.calibrating.tick(until=input_until, keys_waiting=self.input_waiting())
            self._show()

    def _show(self) -> None:
        calibrating = self.calibrating
        held = calibrating.held_s
        state = (round(held, 1), calibrating.repeats, calibrating.result, calibrating.problem)
        if state == self._shown:
            return
        self._shown = state
        text = Text()
        if calibrating.result is not None:
            p = calibrating.result
            text.append("Measured.\n\n", style=f"bold {GOOD}")
            text.append(f"Autorepeat starts after {p.initial_delay_ms:.0f} ms and repeats every "
                        f"{p.repeat_period_ms:.0f} ms.\nHolds under {p.tap_ms:.0f} ms (or not repeated) are level 1; "
                        f"every {p.ms_per_level:.0f} ms more adds a level.\nA tap (no autorepeat) is a move "
                        f"{p.first_repeat_timeout_ms:.0f} ms after the press.\n\n")
            text.append(" enter ", style=KEY_CHIP)
            text.append(" use it   ")
            text.append(" r ", style=KEY_CHIP)
            text.append(" again   ")
            text.append(" esc ", style=KEY_CHIP)
            text.append(" keep the current timing")
        elif calibrating.problem is not None:
            text.append(f"{calibrating.problem[0].upper()}{calibrating.problem[1:]}.\n\n", style=f"bold {SLIP}")
            text.append(" r ", style=KEY_CHIP)
            text.append(" try again   ")
            text.append(" esc ", style=KEY_CHIP)
            text.append(" cancel")
        else:
            text.append("Hold any arrow key down for 2 seconds, then let go.\n\n", style="bold")
            filled = round(BAR_WIDTH * min(1.0, held / HOLD_S))
            text.append(" " * filled, style=f"on {BAR}")
            text.append(" " * (BAR_WIDTH - filled), style=f"on {EMPTY}")
            text.append(f"  {held:.1f} s   {plural(calibrating.repeats, 'repeat')}\n\n")
            text.append("This measures your key repeat; levels count from it.\n\n", style="dim")
            text.append(" esc ", style=KEY_CHIP)
            text.append(" cancel")
        self.query_one("#calibration-text", Static).update(text)
