"""`careful play`'s screen: the play session (`irl_core.play.session`) in a terminal (docs/playing.md).

The player moves with the arrow keys and holds a key longer to be more careful. While a key is
held the gauge fills and the arrow on the player grows; the move is made when the hold ends
(the session infers the end from the autorepeat rhythm, or a kitty release event ends it
exactly). The session keeps every rule: the game, its recording, the input mode, calibration,
the episode count, write failures and quitting. This screen is its terminal front end: it turns
Textual's key events into the session's calls and mirrors the session's `view()` in reactives,
whose changes redraw it (the status and the hold's numbers are drawn by
`careful_tui.widgets.play_status`).

Time: every timing decision reads one injectable `clock` (seconds, `time.monotonic` by
default), the session's, shared by the calibration screen. A key event is timed by when it
reached the app, not when it was handled (`careful_tui.keys.arrival`). A 30 Hz timer runs only
while a move is being entered; it calls `PlayScreen.tick`, which tests call directly after
advancing a fake clock.

Quitting (`q`, Ctrl+C, Ctrl+Q, closing the terminal) quits the session, which records a running
episode that has steps as `quit`. A file that cannot be written ends the game at once; the app
exits and `careful play` then exits 2 with one line.
"""

from __future__ import annotations

import asyncio
import os
import signal

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.binding import Binding
from textual.reactive import var
from textual.screen import Screen
from textual.timer import Timer
from textual.widgets import Static

from careful_tui.keys.arrival import KeyArrival
from careful_tui.keys.kitty import KeyRelease, key_repeat
from careful_tui.render.palette import NOTE, SLIP, WARN
from careful_tui.screens.behind_input import TickBehindInput
from careful_tui.screens.calibration import CalibrationScreen
from careful_tui.screens.game_layout import compose_game
from careful_tui.screens.game_layout import minimum_size as game_minimum_size
from careful_tui.widgets import Arrow, Board, Gauge
from careful_tui.widgets.play_status import GameStatus, HoldInfo
from careful_tui.widgets.too_small import TooSmall
from irl_core.play.game import Cell, Game, MoveResult
from irl_core.play.hold import Clock, HoldProfile, MoveInput
from irl_core.play.input_modes import ARROWS, INPUT_MODES
from irl_core.play.session import HoldView, Message, Played, PlaySession
from irl_core.recordings.lines import EpisodeEnd
from irl_core.recordings.writer import SessionRecorder
from irl_core.support.safe_text import printable
from irl_core.worlds.world import World

FLASH_S = 0.8
TICK_S = 1 / 30


def minimum_size(world: World) -> tuple[int, int]:
    """The smallest terminal (columns, rows) the play screen fits in, for `world`."""
    # As in careful.tcss: the gauge's border, padding and margin; the gauge shows slip chances.
    return game_minimum_size(world, side_padding=5, slips=True)


class PlayScreen(TickBehindInput, Screen[None]):
    """The play screen of one `PlaySession`. Build its app with `careful_tui.app.make_play_app`,
    which the CLI and the tests share.

    Keys are read in `on_key`, which sees every press and autorepeat a hold needs (and is what
    the tests call); the bindings below name the keys in the footer, and `check_action` shows
    those that do something now. A session that plays a set number of episodes (a study's
    block) dismisses the screen when the last has ended and space is pressed. `event_times` says
    whether key events' own times are on the session's clock (`careful_tui.keys.arrival`; None:
    when it is `time.monotonic`).
    """

    TITLE = "careful play"
    BINDINGS = [
        *(Binding(hint.keys, f"move({name!r})", hint.words, key_display=hint.display)
          for name, mode in INPUT_MODES.items() for hint in mode.key_hints),
        Binding(ARROWS.keys, "move('one level')", ARROWS.words, key_display=ARROWS.display),
        Binding("space,enter", "next_episode", "next episode", key_display="space"),
        Binding("space,enter", "next_episode('last')", "go on", key_display="space"),
        Binding("c", "calibrate", "calibrate"),
    ]

    # What the screen shows, mirrored from the session's `view()` by `_mirror` after each call.
    # A change is what redraws: the watchers below move the board's player, arrow and flash and
    # fill the gauge; the status and the hold's numbers are bound to these (`compose`) and
    # repaint once in the next frame however many changed; `live`, `too_small` and `step`
    # leaving or reaching 0 refresh the key bar (what `check_action` answers).
    cell: var[Cell | None] = var(None, init=False)
    episode: var[int] = var(0, init=False)
    step: var[int] = var(0, init=False)
    score: var[float] = var(0.0, init=False)
    live: var[bool] = var(False, init=False, bindings=True)
    last_end: var[EpisodeEnd | None] = var(None, init=False)
    all_played: var[bool] = var(False, init=False)  # the session's set episodes (if any) have ended
    last_move: var[MoveResult | None] = var(None, init=False)
    message: var[Text] = var(Text, init=False)
    hold: var[HoldView | None] = var(None, init=False)
    slipped_to: var[Cell | None] = var(None, init=False)
    too_small: var[bool] = var(False, init=False, bindings=True)
    recording: var[str] = var("", init=False)

    def __init__(self, session: PlaySession, *, event_times: bool | None = None) -> None:
        super().__init__()
        self.session = session
        self.heading = session.options.heading
        self.command = session.options.command
        self.player = session.options.player
        self.input_mode = session.mode.name
        self.world = session.world
        self.clock: Clock = session.clock
        self.arrival = KeyArrival(session.clock, event_times=event_times)
        self._flash: Timer | None = None

    # The session's parts, as the command and the tests read them.
    @property
    def game(self) -> Game:
        return self.session.game

    @property
    def recorder(self) -> SessionRecorder:
        return self.session.recorder

    @property
    def input(self) -> MoveInput:
        return self.session.input

    @property
    def profile(self) -> HoldProfile:
        return self.session.profile

    @property
    def write_error(self) -> OSError | ValueError | None:
        return self.session.write_error

    # ------------------------------------------------------------------ layout

    def compose(self) -> ComposeResult:
        status = GameStatus(self.world, self.session.names, id="status").data_bind(
            PlayScreen.episode, PlayScreen.step, PlayScreen.score, PlayScreen.live, PlayScreen.last_end,
            PlayScreen.message, PlayScreen.all_played)
        hold_info = HoldInfo(self.world, self.session.mode, id="hold-info").data_bind(PlayScreen.hold,
                                                                                     PlayScreen.last_move)
        yield from compose_game(self.world, slips=True, status=status, hold_info=hold_info,
                                show_rewards=self.session.options.show_rewards)

    def on_mount(self) -> None:
        self._ticker = self.set_interval(TICK_S, self._tick_behind_input, pause=True)
        self.session.start()
        self._mirror()
        self._check_size(*self.app.size)
        if not self.app.is_headless:
            loop = asyncio.get_running_loop()
            loop.add_signal_handler(signal.SIGHUP, self.hang_up)
            loop.add_signal_handler(signal.SIGTERM, self.action_quit_game)
        if self.session.options.calibrate:
            self.action_calibrate()

    def on_unmount(self) -> None:
        self.session.quit()

    def on_resize(self, event: events.Resize) -> None:
        self._check_size(event.size.width, event.size.height)

    def _check_size(self, width: int, height: int) -> None:
        self.too_small = self.query_one(TooSmall).check(width, height, minimum_size(self.world), command=self.command)

    def watch_too_small(self, too_small: bool) -> None:
        """The window shrank while a move was being entered: the session drops it, and says so
        (the player cannot see the gauge any more, so the level they were aiming for is not one
        they chose)."""
        if self.session.set_board_visible(not too_small, why="window too small"):
            self.query_one(TooSmall).tell("The move being entered was cancelled.")
            self._mirror()

    # ------------------------------------------------------------------ input

    def on_key(self, event: events.Key) -> None:
        key = event.key
        if key in self.session.keys:
            event.stop()
            event.prevent_default()
            self._show(self.session.press(key, repeat=key_repeat(event), at=self.arrival(event)))
            if self.session.entering():
                self._ticker.resume()
        elif key in ("space", "enter") and not self.session.game.live:
            event.stop()
            event.prevent_default()
            self.action_next_episode()
        elif key == "c":
            event.stop()
            event.prevent_default()
            self.action_calibrate()

    def on_key_release(self, event: KeyRelease) -> None:
        if event.key in self.session.keys:
            self._show(self.session.release(event.key, at=self.arrival(event)))

    def tick(self, *, input_until: float | None = None) -> None:
        """Commit a hold whose release timeout passed by `input_until` (default: now), the time up
        to which every key that came is handled or queued, and show the live gauge and arrow.

        After a stall, keys that came during it can wait in the app's or this screen's queue:
        the silence since the last key handled is then no silence, and ending the hold would
        split one held key into two moves. So the hold ends only when neither queue holds a
        message (`careful_tui.screens.behind_input`, whose `_tick_behind_input` the timer runs).
        """
        self._show(self.session.tick(until=input_until, keys_waiting=self.input_waiting()))
        if not self.session.entering():
            self._ticker.pause()

    def _show(self, played: Played) -> None:
        """Draw what a session call did: a write failure leaves, a slip flashes, a notice pops up."""
        if played.stopped:
            self.app.exit()
            return
        if played.moves:
            self._flash_slip(played.moves[-1])
        for notice in played.notices:
            self.notify(notice, title="recording", severity="warning", timeout=15, markup=False)
        self._mirror()

    # ------------------------------------------------------------------ actions

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """Show and allow the keys that do something now (the footer follows)."""
        if action == "move":  # a world of one level has no carefulness to choose in any mode
            return self.live and parameters == ((self.input_mode,) if self.world.levels > 1 else ("one level",))
        if action == "next_episode":
            return not self.live and self.all_played == (parameters == ("last",))
        if action == "calibrate":
            return self.session.calibration_offered
        return super().check_action(action, parameters)

    def action_move(self, mode: str) -> None:
        """Nothing: `on_key` reads the move keys (these bindings only name them in the footer)."""

    def action_next_episode(self, last: str = "") -> None:
        if self.session.next_episode():
            self.dismiss(None)
            return
        self._mirror()

    def action_quit_game(self) -> None:
        self.session.quit()
        self.app.exit()

    def hang_up(self) -> None:
        """The terminal was closed: record the quit and leave at once.

        Textual's orderly exit writes to the terminal to restore it, and with the terminal gone
        that write blocks forever, so after the recording is safely on disk the process ends
        without it (exit status 129, as for a hang-up).
        """
        self.session.quit()
        os._exit(128 + signal.SIGHUP)

    def action_calibrate(self) -> None:
        refused = self.session.calibration_refused()
        if refused is not None:
            self.notify(refused, title="calibrate")
            return
        calibrating = self.session.start_calibration()
        self._mirror()
        self.app.push_screen(CalibrationScreen(calibrating, event_times=self.arrival.event_times), self.use_profile)

    def use_profile(self, profile: HoldProfile | None) -> None:
        """Play on with `profile` (a calibration's result); None keeps the current one."""
        self.session.use_profile(profile)
        self._mirror()  # a file that has steps is closed: the next move starts a new one

    # ------------------------------------------------------------------ what is shown

    def _mirror(self) -> None:
        """Show the session as it is now (the watchers redraw what changed)."""
        view = self.session.view()
        self.last_move = view.last_move
        self.message = message_text(view.message)
        self.cell, self.episode, self.step, self.score = view.cell, view.episode, view.step, view.score
        self.live, self.last_end, self.all_played = view.live, view.last_end, view.all_played
        self.recording = view.recording
        self.hold = view.hold

    def _flash_slip(self, result: MoveResult) -> None:
        if result.slipped:
            self.slipped_to = result.step.next_state
            if self._flash is not None:
                self._flash.stop()
            self._flash = self.set_timer(FLASH_S, self._end_flash)
        else:
            self.slipped_to = None

    def _end_flash(self) -> None:
        self.slipped_to = None

    # ------------------------------------------------------------------ drawing

    def watch_cell(self, cell: Cell | None) -> None:
        self.query_one(Board).player = cell

    def watch_step(self, old: int, new: int) -> None:
        if (old == 0) != (new == 0):  # calibration is offered before an episode's first move
            self.refresh_bindings()

    def watch_hold(self, view: HoldView | None) -> None:
        gauge, board = self.query_one(Gauge), self.query_one(Board)
        gauge.level, gauge.fill = (None, 0.0) if view is None else (view.level, view.fill)
        board.arrow = None if view is None or view.key is None else Arrow(view.key, view.fill, self.world.levels)

    def watch_slipped_to(self, cell: Cell | None) -> None:
        self.query_one(Board).highlight = {} if cell is None else {cell: SLIP}

    def watch_recording(self, where: str) -> None:
        self.query_one("#title", Static).update(Text.assemble(
            (printable(self.heading, limit=60), f"bold {NOTE}"), " · player ", (printable(self.player, limit=40), "bold"),
            f" · {self.input_mode} input", (f" · recording → {printable(where, limit=200)}", "dim"),
        ), layout=False)


MESSAGE_STYLES = {"": "", "slip": SLIP, "note": NOTE, "warn": WARN}


def message_text(message: Message) -> Text:
    """A session's message as the status line draws it: its lead strong in its kind's colour."""
    style = MESSAGE_STYLES[message.kind]
    if message.lead:
        return Text.assemble((message.lead, f"bold {style}"), message.text)
    return Text(message.text, style=style)
