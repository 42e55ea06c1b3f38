"""The study's motor calibration block in a terminal: "hold until the gauge shows k, then let go".

It draws one `irl_core.play.motor_block.MotorBlock` (the flow's `calibration`): the target, the
gauge filling while an arrow is held, and what the last hold made, in the block's own words (the
browser shows the same). Keys are timed as in play (`careful_tui.keys.arrival`, kitty releases
when the terminal sends them, else the silence after the last autorepeat, judged behind the keys
already read). When every target has a trial, space goes on to practice (or the game, in a study
without practice); q leaves, keeping the trials written so far (a participant run again is asked
the rest).
"""

from __future__ import annotations

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.containers import Horizontal, Vertical
from textual.screen import Screen
from textual.widgets import Static

from careful_tui.keys.arrival import KeyArrival
from careful_tui.keys.kitty import KeyRelease, key_repeat
from careful_tui.render.palette import GOOD, NOTE
from careful_tui.screens.behind_input import TickBehindInput
from careful_tui.widgets import Gauge, KeyBar
from irl_core.play.game import level_costs, level_slip_chances
from irl_core.play.motor_block import MOTOR_INTRO, MOTOR_TITLE, MotorBlock, result_words
from irl_core.worlds.world import World


class MotorScreen(TickBehindInput, Screen[bool]):
    """The calibration block's targets, one at a time; dismissed with True when all are done, False
    when the participant leaves (q) or a trial cannot be written."""

    def __init__(self, block: MotorBlock, world: World, *, event_times: bool | None = None) -> None:
        super().__init__()
        # The go-on key's words are the block's (practice next, or the game), as the browser shows them.
        self._bindings.bind("space,enter", "go_on", block.view().begin, key_display="space")
        self.block = block
        self.world = world
        self.clock = block.clock
        self.arrival = KeyArrival(block.clock, event_times=event_times)

    def compose(self) -> ComposeResult:
        with Vertical(id="motor-box") as box:
            box.border_title = MOTOR_TITLE.lower()
            yield Static(Text(MOTOR_INTRO, style="dim"), id="motor-intro")
            with Horizontal(id="motor-row"):
                # The browser's gauge: each level's cost and chance of slipping, the target marked.
                gauge = Gauge(level_costs(self.world), slips=level_slip_chances(self.world), id="motor-gauge")
                gauge.border_title, gauge.border_subtitle = "carefulness", "points slip"  # as in play
                yield gauge
                yield Static(id="motor-text")
        yield KeyBar(id="keys")

    def on_mount(self) -> None:
        self._ticker = self.set_interval(1 / 30, self._tick_behind_input)
        self._show()

    def on_key(self, event: events.Key) -> None:
        key, block = event.key, self.block
        if key in block.keys and not block.done:
            event.stop()
            event.prevent_default()
            block.press(key, repeat=key_repeat(event), at=self.arrival(event))
        elif key == "q":
            event.stop()
            event.prevent_default()
            self.dismiss(False)
            return
        self._show()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "go_on":
            return self.block.done
        return super().check_action(action, parameters)

    def action_go_on(self) -> None:
        """Space once every target has a trial: on to practice (or out, when a trial could not be written)."""
        if self.block.done:
            self.dismiss(self.block.write_error is None)

    def on_key_release(self, event: KeyRelease) -> None:
        if event.key in self.block.keys:
            self.block.release(event.key, at=self.arrival(event))
            self._show()

    def tick(self, *, input_until: float | None = None) -> None:
        """End a hold whose silence ran out by `input_until` (no key waiting to be handled); redraw."""
        if self.block.entering():
            self.block.tick(until=input_until, keys_waiting=self.input_waiting())
        self._show()

    def _show(self) -> None:
        view = self.block.view()
        if view.done != getattr(self, "_done_shown", None):
            self._done_shown = view.done
            self.refresh_bindings()
        gauge = self.query_one("#motor-gauge", Gauge)
        gauge.fill = view.hold.fill if view.hold is not None else 0.0
        gauge.level = view.hold.level if view.hold is not None else None
        gauge.target = view.target
        text = Text()
        if view.done:
            if self.block.write_error is not None:
                text.append(f"The trials could not be written: {self.block.write_error}\n\n", style="bold red")
                text.append("Press space to leave.", style="dim")
            else:
                text.append(f"{view.instruction}\n\n", style=f"bold {GOOD}")
                text.append(f"Press space to {view.begin}. q leaves; what you did is kept.", style="dim")
        else:
            text.append(f"{view.number} of {view.count}\n\n", style=f"bold {NOTE}")
            text.append(f"{view.instruction}\n\n", style="bold")
            held = f"Now: level {view.hold.level}" if view.hold is not None else " "
            text.append(f"{held}\n\n")
            text.append("q leaves; what you did is kept.", style="dim")
        if view.last is not None and not view.done:
            text.append(f"\n\nLast: {result_words(view.last)}", style="dim")
        self.query_one("#motor-text", Static).update(text)
