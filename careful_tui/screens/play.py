"""`careful play`: the paper's cliff game, recorded step by step (recordings/README.md, README "What it does" and "Playing").

The player moves with the arrow keys and holds a key longer to be more careful. While a key is
held the gauge fills and the arrow on the player grows; the move is made when the hold ends
(`careful_tui.keys.hold` infers the end from the autorepeat rhythm, or a kitty release event ends it
exactly). The rules and the recording live in `irl_core.game`; this module is the screen, which
mirrors what it shows in reactives whose changes redraw it (the status and the hold's numbers
are drawn by `careful_tui.widgets.play_status`).

Time: every timing decision reads one injectable `clock` (seconds, `time.monotonic` by
default), shared by the input detector, the live gauge and the calibration screen. A key event
is timed by when it reached the app, not when it was handled (`careful_tui.keys.arrival`). A 30 Hz
timer runs only while a move is being entered; it calls `PlayScreen.tick`, which tests call
directly after advancing a fake clock.

Recording: the session file (`recordings/<time>-<player>.jsonl`) is created at the first
move, so a calibration made before anything was played goes into its header. Calibration is
offered whenever no episode is half played (before an episode's first move or after its end);
if the file already holds steps, the calibrated profile starts a new session file, whose
episodes continue the numbering. Quitting (`q`, Ctrl+C, Ctrl+Q, closing the terminal) records
a running episode that has steps as `quit`; a hold still being entered is not a move and is
dropped.

Failures: a recordings folder deleted mid-session is recreated and the session goes on in a
new file holding every step so far (`SessionRecorder`), and the player is told. A file that
cannot be written (a full disk, a folder made read-only) ends the game at once: nothing more
can be recorded, so nothing more is played; `careful play` then exits 2 with one line.
"""

from __future__ import annotations

import asyncio
import os
import signal
import time

from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.binding import Binding
from textual.reactive import var
from textual.screen import Screen
from textual.timer import Timer
from textual.widgets import Static

from careful_tui.keys.arrival import KeyArrival
from careful_tui.keys.hold import ActiveHold, Clock, Hold, HoldProfile, MoveInput
from careful_tui.keys.modes import make_input
from careful_tui.keys.kitty import KeyRelease, key_repeat
from careful_tui.render.palette import NOTE, SLIP, WARN
from careful_tui.screens.behind_input import TickBehindInput
from careful_tui.screens.calibration import CalibrationScreen
from careful_tui.screens.game_layout import compose_game, minimum_size as game_minimum_size
from careful_tui.widgets import Arrow, Board, Gauge
from careful_tui.widgets.play_status import EpisodeNames, GameStatus, HoldInfo, HoldView
from careful_tui.widgets.too_small import TooSmall
from irl_core.recording_writer import SessionRecorder
from irl_core.game import Cell, Game, MoveResult
from irl_core.recording_lines import EpisodeEnd
from irl_core.safe_text import printable
from irl_core.world import World

FLASH_S = 0.8
TICK_S = 1 / 30


def minimum_size(world: World) -> tuple[int, int]:
    """The smallest terminal (columns, rows) the play screen fits in, for `world`."""
    # As in careful.tcss: the gauge's border, padding and margin; the gauge shows slip chances.
    return game_minimum_size(world, side_padding=5, slips=True)


class PlayScreen(TickBehindInput, Screen[None]):
    """The play screen. Build its app with `careful_tui.app.make_play_app`, which the CLI and the tests share.

    Keys are read in `on_key`, which sees every press and autorepeat a hold needs (and is what
    the tests call); the bindings below name the keys in the footer, and `check_action` shows
    those that do something now.

    A study plays a set number of episodes on it: `episodes` (then space dismisses the screen),
    `episodes_done` of the `episodes_done + episodes` already played before, each called an
    `episode_word` ("Practice episode 1 of 2"), under the title `heading`; `command` names what a
    too-small terminal is told needs more room. `event_times` says whether key events' own
    times are on `clock` (`careful_tui.keys.arrival`; None: when `clock` is `time.monotonic`).
    """

    TITLE = "careful play"
    BINDINGS = [
        Binding("up,right,down,left", "move('hold')", "move · hold longer: more careful", key_display="←↑→↓"),
        Binding("up,right,down,left", "move('tap')", "move · tap ×k: level k", key_display="←↑→↓"),
        Binding("1,2,3,4,5,6,7,8,9", "move('digits')", "level", key_display="1-9"),
        Binding("up,right,down,left", "move('digits')", "move", key_display="←↑→↓"),
        Binding("backspace", "move('digits')", "fix", key_display="⌫"),
        Binding("up,right,down,left", "move('one level')", "move", key_display="←↑→↓"),
        Binding("space,enter", "next_episode", "next episode", key_display="space"),
        Binding("space,enter", "next_episode('last')", "go on", key_display="space"),
        Binding("c", "calibrate", "calibrate"),
    ]

    # What the screen shows, mirrored from `game`, `recorder` and `input` (which keep the rules,
    # the recording and the move being entered) by `_mirror` and `_mirror_hold` after each change
    # of them. A change is what redraws: the watchers below move the board's player, arrow and
    # flash and fill the gauge; the status and the hold's numbers are bound to these (`compose`)
    # and repaint once in the next frame however many changed; `live`, `too_small` and `step`
    # leaving or reaching 0 refresh the key bar (what `check_action` answers).
    cell: var[Cell | None] = var(None, init=False)
    episode: var[int] = var(0, init=False)
    step: var[int] = var(0, init=False)
    score: var[float] = var(0.0, init=False)
    live: var[bool] = var(False, init=False, bindings=True)
    last_end: var[EpisodeEnd | None] = var(None, init=False)
    all_played: var[bool] = var(False, init=False)  # the episodes this screen was given (if any) have ended
    last_move: var[MoveResult | None] = var(None, init=False)
    message: var[Text] = var(Text, init=False)
    hold: var[HoldView | None] = var(None, init=False)
    slipped_to: var[Cell | None] = var(None, init=False)
    too_small: var[bool] = var(False, init=False, bindings=True)
    recording: var[str] = var("", init=False)

    def __init__(
        self,
        game: Game,
        recorder: SessionRecorder,
        *,
        input_mode: str = "hold",
        profile: HoldProfile | None = None,
        clock: Clock = time.monotonic,
        calibrate: bool = False,
        player: str = "player",
        heading: str = "careful play",
        episodes: int | None = None,
        episodes_done: int = 0,
        episode_word: str = "Episode",
        command: str = "careful play",
        event_times: bool | None = None,
    ) -> None:
        super().__init__()
        self.heading = heading
        self.command = command
        self.names = EpisodeNames(episode_word, game.first_episode, episodes, episodes_done)
        self.game = game
        self.recorder = recorder
        self.world = game.world
        self.clock = clock
        self.arrival = KeyArrival(clock, event_times=event_times)
        self.player = player
        self.input_mode = input_mode
        self.profile = profile or HoldProfile(levels=self.world.levels)
        self.input: MoveInput = make_input(input_mode, self.profile, clock=clock)
        self.releases_seen = False
        self._calibrate_at_start = calibrate
        self._last_key_at: float | None = None
        self._flash: Timer | None = None
        self.write_error: OSError | ValueError | None = None

    # ------------------------------------------------------------------ layout

    def compose(self) -> ComposeResult:
        status = GameStatus(self.world, self.names, id="status").data_bind(
            PlayScreen.episode, PlayScreen.step, PlayScreen.score, PlayScreen.live, PlayScreen.last_end,
            PlayScreen.message, PlayScreen.all_played)
        hold_info = HoldInfo(self.world, self.input_mode, id="hold-info").data_bind(PlayScreen.hold,
                                                                                   PlayScreen.last_move)
        yield from compose_game(self.world, slips=True, status=status, hold_info=hold_info)

    def on_mount(self) -> None:
        self._ticker = self.set_interval(TICK_S, self._tick_behind_input, pause=True)
        self.game.begin_episode()
        self._mirror()
        self._check_size(*self.app.size)
        if not self.app.is_headless:
            loop = asyncio.get_running_loop()
            loop.add_signal_handler(signal.SIGHUP, self.hang_up)
            loop.add_signal_handler(signal.SIGTERM, self.action_quit_game)
        if self._calibrate_at_start:
            self.action_calibrate()

    def on_unmount(self) -> None:
        self.record_quit()

    def on_resize(self, event: events.Resize) -> None:
        self._check_size(event.size.width, event.size.height)

    def _check_size(self, width: int, height: int) -> None:
        self.too_small = self.query_one(TooSmall).check(width, height, minimum_size(self.world), command=self.command)

    def watch_too_small(self, too_small: bool) -> None:
        """The window shrank while a move was being entered: drop it, and say so.

        The player cannot see the gauge any more, so the level they were aiming for is not one
        they chose: no move is better than a move at a level nobody saw.
        """
        if too_small and self.input.current() is not None:
            self.input.cancel()
            self._mirror_hold()
            self.query_one(TooSmall).tell("The move being entered was cancelled.")
            self.message = Text("Move cancelled (window too small).", style=WARN)

    # ------------------------------------------------------------------ input

    def on_key(self, event: events.Key) -> None:
        key = event.key
        if key in self.input.keys:
            event.stop()
            event.prevent_default()
            if self.game.live and self.too_small:
                # No move while the board cannot be seen, nor later from this key's autorepeats
                # (nothing is being entered while the window is too small, so nothing ends here).
                self.input.press(key, repeat=key_repeat(event), at=self.arrival(event))
                self.input.cancel()
            elif self.game.live:
                self._last_key_at = self.arrival(event)
                self._commit(self.input.press(key, repeat=key_repeat(event), at=self._last_key_at))
                self._mirror_hold()
                if self.input.deadline() is not None or self.input.current() is not None:
                    self._ticker.resume()
        elif key in ("space", "enter") and not self.game.live:
            event.stop()
            event.prevent_default()
            self.action_next_episode()
        elif key == "c":
            event.stop()
            event.prevent_default()
            self.action_calibrate()

    def on_key_release(self, event: KeyRelease) -> None:
        if event.key in self.input.keys:
            self.releases_seen = True
            self._commit(self.input.release(event.key, at=self.arrival(event)))
            self._mirror_hold()

    def tick(self, *, input_until: float | None = None) -> None:
        """Commit a hold whose release timeout passed by `input_until` (default: now), the time up
        to which every key that came is handled or queued, and show the live gauge and arrow.

        After a stall, keys that came during it can wait in the app's or this screen's queue:
        the silence since the last key handled is then no silence, and ending the hold would
        split one held key into two moves. So the hold ends only when neither queue holds a
        message (`careful_tui.screens.behind_input`, whose `_tick_behind_input` the timer runs).
        """
        if not self.input_waiting():
            self._commit(self.input.poll(at=input_until))
        self._mirror_hold()
        if self.input.current() is None and self.input.deadline() is None:
            self._ticker.pause()

    def _commit(self, holds: list[Hold]) -> None:
        for hold in holds:
            if not self.game.live:
                break
            try:
                result = self.game.move(hold.key, hold.level, hold_ms=hold.hold_ms, exact=hold.exact)
            except (OSError, ValueError) as exc:
                self.stop_on_write_error(exc)
                return
            self.last_move = result
            self._show_move(result)
            if result.end is not None:
                self.input.reset()
        if holds:
            self._show_notices()
            self._mirror()

    def stop_on_write_error(self, error: OSError | ValueError) -> None:
        """The recording cannot be written: play no further (`run_play` reports it)."""
        self.write_error = error
        self.input.reset()
        self.game.live = False
        self.app.exit()

    def _show_notices(self) -> None:
        """Tell the player what the recorder did on its own (a deleted folder recreated)."""
        while self.recorder.notices:
            notice = printable(self.recorder.notices.pop(0), limit=300)
            self.message = Text(notice, style=NOTE)
            self.notify(notice, title="recording", severity="warning", timeout=15, markup=False)

    # ------------------------------------------------------------------ actions

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """Show and allow the keys that do something now (the footer follows)."""
        if action == "move":  # a world of one level has no carefulness to choose in any mode
            return self.live and parameters == ((self.input_mode,) if self.world.levels > 1 else ("one level",))
        if action == "next_episode":
            return not self.live and self.all_played == (parameters == ("last",))
        if action == "calibrate":
            return self.input_mode == "hold" and self.world.levels > 1 and (not self.live or self.step == 0)
        return super().check_action(action, parameters)

    def action_move(self, mode: str) -> None:
        """Nothing: `on_key` reads the move keys (these bindings only name them in the footer)."""

    def action_next_episode(self, last: str = "") -> None:
        if self.all_played:
            self.dismiss(None)
            return
        self.game.begin_episode()
        self.message = Text()
        self._mirror()

    def action_quit_game(self) -> None:
        self.record_quit()
        self.app.exit()

    def hang_up(self) -> None:
        """The terminal was closed: record the quit and leave at once.

        Textual's orderly exit writes to the terminal to restore it, and with the terminal gone
        that write blocks forever, so after the recording is safely on disk the process ends
        without it (exit status 129, as for a hang-up).
        """
        self.record_quit()
        os._exit(128 + signal.SIGHUP)

    def record_quit(self) -> None:
        """End a running episode as `quit` and close the file (safe to call more than once)."""
        self.input.reset()
        try:
            self.game.quit()
            self.recorder.close()
        except (OSError, ValueError) as exc:
            self.write_error = self.write_error or exc

    def action_calibrate(self) -> None:
        if self.input_mode != "hold":
            self.notify(f"Calibration measures how your keyboard repeats a held key; {self.input_mode} input "
                        "does not time holds.", title="calibrate")
            return
        if self.game.live and self.game.t > 0:
            self.notify("Calibrate before an episode's first move or after it ends.", title="calibrate")
            return
        self.input.reset()
        self._mirror_hold()
        calibration = CalibrationScreen(self.profile, clock=self.clock, event_times=self.arrival.event_times)
        self.app.push_screen(calibration, self.use_profile)

    def use_profile(self, profile: HoldProfile | None) -> None:
        """Play on with `profile` (a calibration's result); None keeps the current one."""
        if profile is None:
            return
        self.profile = profile
        self.input = make_input(self.input_mode, profile, clock=self.clock)
        self.recorder.set_header(self.recorder.header.model_copy(update={"input": self.input.header()}))
        # One line of at most 42 characters: the status at the smallest terminal.
        self.message = Text(f"Calibrated: a tap is a move after {profile.first_repeat_timeout_ms:.0f} ms.", style=NOTE)
        self._mirror()  # a file that has steps is closed: the next move starts a new one

    # ------------------------------------------------------------------ what is shown

    def _mirror(self) -> None:
        """Show the game and its recording as they are now (the watchers redraw what changed)."""
        game, path = self.game, self.recorder.path
        self.cell, self.episode, self.step, self.score = game.cell, game.episode, game.t, game.score
        self.live, self.last_end = game.live, game.last_end
        self.all_played = self.names.all_played(game.episode, game.live)
        self.recording = str(path) if path is not None else f"{self.recorder.folder}{os.sep}"

    def _mirror_hold(self) -> None:
        """Show the move being entered, if any."""
        current = self.input.current()
        self.hold = None if current is None else self._hold_view(current)

    def _show_move(self, result: MoveResult) -> None:
        step = result.step
        if result.slipped:
            self.message = Text.assemble(("slipped! ", f"bold {SLIP}"),
                                         f"you went {result.realised} instead of {step.direction}")
            self.slipped_to = step.next_state
            if self._flash is not None:
                self._flash.stop()
            self._flash = self.set_timer(FLASH_S, self._end_flash)
        else:
            self.message = Text()
            self.slipped_to = None

    def _end_flash(self) -> None:
        self.slipped_to = None

    def _hold_view(self, current: ActiveHold) -> HoldView:
        """The move being entered as shown: its level, gauge fill and hold ms.

        In hold mode without release events a hold with no autorepeat yet is a tap (level 1)
        and a hold shows no more than one repeat period past its last key event, so the
        gauge never shows a level the move will not get.
        """
        if self.input_mode != "hold":
            return HoldView(current.key, current.level, float(current.level), current.elapsed_ms)
        p = self.profile
        shown_ms = current.elapsed_ms
        if not self.releases_seen:
            if current.repeats == 0:
                return HoldView(current.key, 1, 1 + 0.9 * min(1.0, shown_ms / p.initial_delay_ms), shown_ms)
            if self._last_key_at is not None:
                started = self.clock() - current.elapsed_ms / 1000
                shown_ms = min(shown_ms, (self._last_key_at - started) * 1000 + p.repeat_period_ms)
        level = p.level_for(shown_ms)
        if shown_ms < p.initial_delay_ms:
            fill = 1 + shown_ms / p.initial_delay_ms
        else:
            fill = 2 + (shown_ms - p.initial_delay_ms) / p.ms_per_level
        return HoldView(current.key, level, min(fill, level + 0.999, float(p.levels)), shown_ms)

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
