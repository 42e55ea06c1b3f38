"""One play session, for any front end: the game, its recording, the move being entered.

A front end (the terminal's `PlayScreen`, the browser's server) turns its key events into calls
and draws what `view()` answers; the session keeps every rule of the session in between:

- the game's rules are `irl_core.play.game.Game`'s, the recording `irl_core.recordings.writer`'s;
- keys become moves through the input mode (`irl_core.play.input_modes`) on one timing profile,
  which a calibration can replace (offered while no episode is half played; a file that already
  holds steps is closed, and the next move starts a new one with the calibrated header);
- a session may play a set number of episodes (a study's block): then `next_episode` after the
  last answers that the block is over;
- a file that cannot be written (a full disk, a read-only folder) stops the session at once:
  nothing more can be recorded, so nothing more is played (`write_error`, `Played.stopped`);
  a deleted recordings folder is recreated by the recorder, and the session says so
  (`Played.notices`);
- `quit` records a running episode that has steps as ``quit`` and closes the file; a move still
  being entered is not a move and is dropped.

On a time world (``care = "time"``) the move is the hold itself: its exact length, from `press` to
`release`; a hold the session could only infer from autorepeats is dropped with a warning.

Time: every call takes the time its key event happened (`at`, seconds on the session's
`clock`; default: the clock now). A front end that knows when a key went down and when it came
up (a browser's keydown and keyup, a kitty terminal) calls `press(key, at=t0)` and
`release(key, at=t1)`, and the move is recorded with ``hold_ms = 1000 * (t1 - t0)`` and
``hold_exact: true``. One that sees only presses and autorepeats (a legacy terminal) calls
`press` for each and `tick` at about 30 Hz while `entering()`: the hold ends by the silence
after it. `docs/play-session.md` describes the interface.

No front end is imported here (a test holds it to that).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Literal

from irl_core.play.calibration import Calibrating
from irl_core.play.game import Cell, Game, MoveResult
from irl_core.play.hold import ActiveHold, Clock, Hold, HoldProfile, MoveInput
from irl_core.play.input_modes import DEFAULT_INPUT_MODE, InputMode, input_mode
from irl_core.recordings.lines import EpisodeEnd, SessionHeader, StudyTag
from irl_core.recordings.writer import SessionRecorder
from irl_core.support.safe_text import printable
from irl_core.worlds.world import World

MessageKind = Literal["", "slip", "note", "warn"]


@dataclass(frozen=True)
class PlayOptions:
    """How a session plays: its input mode and profile, its player, its episodes and titles.

    Attributes:
        input_mode: a registered mode's name (`irl_core.play.input_modes`); another name raises
            `ValueError` here.
        profile: the timing profile (default: the uncalibrated one, on the world's levels).
        calibrate: the front end opens calibration before the first move (`start_calibration`).
        player: the player's name, as recorded.
        heading: the session's title ("careful play", a study block's place).
        command: what a front end names when its window is too small to play in.
        episodes: how many episodes the session plays (None: as many as the player likes).
        episodes_done: episodes of the same block played before (they count in "3 of 5").
        episode_word: what an episode is called ("Episode", "Practice episode").
        show_rewards: the board's legend gives each symbol's reward (a study's ``show_rewards``); without
            it, names only. Both front ends draw their legend from `legend_entries` with it.
    """

    input_mode: str = DEFAULT_INPUT_MODE
    profile: HoldProfile | None = None
    calibrate: bool = False
    player: str = "player"
    heading: str = "careful play"
    command: str = "careful play"
    episodes: int | None = None
    episodes_done: int = 0
    episode_word: str = "Episode"
    show_rewards: bool = True

    def __post_init__(self) -> None:
        input_mode(self.input_mode)

    @property
    def mode(self) -> InputMode:
        return input_mode(self.input_mode)


@dataclass(frozen=True)
class EpisodeNames:
    """How a session names its game's episodes: each is a `word` ("Practice episode"), numbered
    from 1, or, when the session plays a set `count` of them after `done` played before, within
    those ("1 of 2"). `first` is the game's first episode number."""

    word: str = "Episode"
    first: int = 0
    count: int | None = None
    done: int = 0

    def number(self, episode: int) -> str:
        """The number shown for the game's episode `episode`: "3", or "1 of 2"."""
        if self.count is None:
            return f"{episode + 1}"
        return f"{self.done + episode - self.first + 1} of {self.done + self.count}"

    def all_played(self, episode: int, live: bool) -> bool:
        """Whether the `count` episodes (if any) have all ended, `episode` being the last begun."""
        return self.count is not None and not live and episode + 1 - self.first >= self.count


@dataclass(frozen=True)
class Message:
    """One line for the player: `lead` (drawn strong, "slipped! ") then `text`, coloured by `kind`
    ("" plain, "slip", "note" for news, "warn" for a problem)."""

    text: str = ""
    kind: MessageKind = ""
    lead: str = ""


@dataclass(frozen=True)
class HoldView:
    """The move being entered, as shown: its arrow key (None in digits mode before the arrow),
    level, the gauge's fill (in levels: 1.0 empty at level 1, up to `levels`) and the ms held."""

    key: str | None
    level: int
    fill: float
    held_ms: float


@dataclass(frozen=True)
class Played:
    """What a call did besides changing `view()`: the moves it made, in order, what the recorder
    did on its own (a deleted folder recreated), and whether a write failure stopped the session
    (`PlaySession.write_error` says why; a front end then leaves)."""

    moves: tuple[MoveResult, ...] = ()
    notices: tuple[str, ...] = ()
    stopped: bool = False


@dataclass(frozen=True)
class SessionView:
    """What a front end draws, as it is now.

    Attributes:
        cell: the player's cell (None before the first episode).
        episode, step, score: the game's episode number, its steps so far, its score.
        live: an episode is running (moves are taken); else space begins the next.
        last_end: how the last episode ended (None before any ended).
        all_played: the session's set episodes (if any) have all ended: `next_episode` ends the block.
        last_move: the last move made (None before any).
        message: the line for the player.
        hold: the move being entered, for the gauge and the arrow (None: nothing being entered).
        recording: the file being written, or the folder (ending in a separator) before it is made.
        calibration_offered: calibration applies now (a key for it is worth showing).
    """

    cell: Cell | None
    episode: int
    step: int
    score: float
    live: bool
    last_end: EpisodeEnd | None
    all_played: bool
    last_move: MoveResult | None
    message: Message
    hold: HoldView | None
    recording: str
    calibration_offered: bool


class PlaySession:
    """A game played move by move from a front end's key events, and recorded as it goes.

    Build one with `new_session` (it makes the recorder and the game). Call `start` once, then
    feed `press`, `release` and `tick`; draw `view()` after each call. `keys` are the keys the
    input mode takes (the arrows; digits mode also the digits, Backspace and Escape).
    """

    def __init__(self, game: Game, recorder: SessionRecorder, options: PlayOptions = PlayOptions(),
                 *, clock: Clock = time.monotonic) -> None:
        self.game = game
        self.recorder = recorder
        self.world: World = game.world
        self.options = options
        self.mode = options.mode
        self.clock = clock
        self.profile = options.profile or HoldProfile(levels=self.world.levels)
        self.input: MoveInput = self.mode.make(self.profile, clock)
        self.names = EpisodeNames(options.episode_word, game.first_episode, options.episodes, options.episodes_done)
        self.releases_seen = False
        self.last_move: MoveResult | None = None
        self.message = Message()
        self.write_error: OSError | ValueError | None = None
        self.board_visible = True
        self._last_key_at: float | None = None

    @property
    def keys(self) -> frozenset[str]:
        return self.input.keys

    def start(self) -> None:
        """Begin the first episode."""
        self.game.begin_episode()

    # ------------------------------------------------------------------ keys

    def press(self, key: str, *, at: float | None = None, repeat: bool | None = None) -> Played:
        """A key went down (or autorepeated) at `at`. `repeat`: True for an autorepeat, False for
        a fresh press, None when the front end cannot tell (a legacy terminal). Keys outside
        `keys`, and keys while no episode runs, do nothing."""
        if key not in self.input.keys or not self.game.live:
            return Played()
        at = self.clock() if at is None else at
        if not self.board_visible:
            # No move while the board cannot be seen, nor later from this key's autorepeats.
            self.input.press(key, repeat=repeat, at=at)
            self.input.cancel()
            return Played()
        self._last_key_at = at
        return self._commit(self.input.press(key, repeat=repeat, at=at))

    def release(self, key: str, *, at: float | None = None) -> Played:
        """A key came up at `at`: a hold on it ends, its length measured exactly."""
        if key not in self.input.keys:
            return Played()
        self.releases_seen = True
        return self._commit(self.input.release(key, at=at))

    def tick(self, *, until: float | None = None, keys_waiting: bool = False) -> Played:
        """Time passed: end a move whose silence ran out by `until` (default: now), the time up to
        which every key event that came has been fed. `keys_waiting`: key events that came are
        still queued in the front end, so the silence is no silence and nothing ends."""
        if keys_waiting or self.world.care == "time":
            # A time world's hold ends only by its key-up: a silence (a busy machine's gap between repeats)
            # is the key still down.
            return Played()
        return self._commit(self.input.poll(at=until))

    def deadline(self) -> float | None:
        """When the move being entered ends by silence (clock seconds), if nothing comes first (never on a
        time world, whose holds end by their key-up)."""
        return None if self.world.care == "time" else self.input.deadline()

    def entering(self) -> bool:
        """A move is being entered, or waits for its silence: a front end keeps calling `tick`."""
        return self.input.current() is not None or self.input.deadline() is not None

    def cancel_hold(self, why: str) -> bool:
        """Drop the move being entered (the window lost focus, or shrank): no move is better than
        one at a level the player did not see. Its key is ignored until it is let go. Returns
        whether there was one; the message says `why` it went."""
        if self.input.current() is None:
            return False
        self.input.cancel()
        self.message = Message(f"Move cancelled ({why}).", "warn")
        return True

    def set_board_visible(self, visible: bool, *, why: str = "window too small") -> bool:
        """The board can (or cannot) be seen. While it cannot, keys make no move, and a move being
        entered as it goes is cancelled (returns whether one was)."""
        self.board_visible = visible
        return False if visible else self.cancel_hold(why)

    # ------------------------------------------------------------------ episodes

    def next_episode(self) -> bool:
        """Begin the next episode, once the last has ended. Returns True instead when the
        session's set episodes are all played: the block is over (nothing begins)."""
        if self.game.live:
            return False
        if self.names.all_played(self.game.episode, self.game.live):
            return True
        self.game.begin_episode()
        self.message = Message()
        return False

    def quit(self) -> None:
        """End a running episode that has steps as ``quit`` and close the file (safe to call more
        than once; a write failure is kept in `write_error`)."""
        self.input.reset()
        try:
            self.game.quit()
            self.recorder.close()
        except (OSError, ValueError) as exc:
            self.write_error = self.write_error or exc

    # ------------------------------------------------------------------ calibration

    @property
    def calibration_offered(self) -> bool:
        """Calibration applies here and now: the mode times holds, the world has levels to time (a time
        world has none), and no episode is half played."""
        return (self.mode.times_holds and self.world.levels > 1 and self.world.care != "time"
                and (not self.game.live or self.game.t == 0))

    def calibration_refused(self) -> str | None:
        """Why calibration cannot start now (a sentence for the player), or None when it can."""
        if self.world.care == "time":
            return "This world has no levels to calibrate: your hold itself is the care."
        if not self.mode.times_holds:
            return (f"Calibration measures how your keyboard repeats a held key; {self.mode.name} input "
                    "does not time holds.")
        if self.game.live and self.game.t > 0:
            return "Calibrate before an episode's first move or after it ends."
        return None

    def start_calibration(self) -> Calibrating:
        """Drop the move being entered and measure the keyboard from the current profile; hand
        the result to `use_profile`.

        Raises:
            ValueError: calibration is refused now (`calibration_refused` says why).
        """
        refused = self.calibration_refused()
        if refused is not None:
            raise ValueError(refused)
        self.input.reset()
        return Calibrating(self.profile, clock=self.clock)

    def use_profile(self, profile: HoldProfile | None) -> None:
        """Play on with `profile` (a calibration's result); None keeps the current one. A file
        that holds steps is closed: the next move starts a new one under the new header."""
        if profile is None:
            return
        self.profile = profile
        self.input = self.mode.make(profile, self.clock)
        self.recorder.set_header(self.recorder.header.model_copy(update={"input": self.input.header()}))
        # One line of at most 42 characters: the status at the smallest terminal.
        self.message = Message(f"Calibrated: a tap is a move after {profile.first_repeat_timeout_ms:.0f} ms.", "note")

    # ------------------------------------------------------------------ what is shown

    def view(self) -> SessionView:
        game, path = self.game, self.recorder.path
        return SessionView(
            cell=game.cell, episode=game.episode, step=game.t, score=game.score, live=game.live,
            last_end=game.last_end, all_played=self.names.all_played(game.episode, game.live),
            last_move=self.last_move, message=self.message, hold=self.hold_view(),
            recording=str(path) if path is not None else f"{self.recorder.folder}{os.sep}",
            calibration_offered=self.calibration_offered,
        )

    def hold_view(self) -> HoldView | None:
        """The move being entered as shown (`entering_view`); None when nothing is being entered."""
        return entering_view(self.input, self.mode, self.profile, releases_seen=self.releases_seen,
                             last_key_at=self._last_key_at, now=self.clock())

    # ------------------------------------------------------------------ moves

    def _commit(self, holds: list[Hold]) -> Played:
        moves: list[MoveResult] = []
        for hold in holds:
            if not self.game.live:
                break
            timed = self.game.world.care == "time"
            if timed and not hold.exact:
                # A time world's care is the hold itself: one guessed from autorepeats is not a move.
                self.message = Message("this world times each hold from key-down to key-up, and this terminal "
                                       "did not report the key-up: play it in the browser or in kitty", "warn")
                continue
            try:
                result = self.game.move(hold.key, None if timed else hold.level, hold_ms=hold.hold_ms,
                                        exact=hold.exact)
            except (OSError, ValueError) as exc:
                self._stop(exc)
                return Played(tuple(moves), stopped=True)
            if result is None:
                # One line of at most 42 characters: the status at the smallest terminal.
                went = self.game.last_dropped
                self.message = Message(f"{hold.key}: blocked, no move made" if went == hold.key
                                       else f"{hold.key} slipped {went}, blocked: no move", "note")
                continue
            moves.append(result)
            self.last_move = result
            self.message = (Message(f"you went {result.realised} instead of {result.step.direction}", "slip",
                                    lead="slipped! ") if result.slipped else Message())
            if result.end is not None:
                self.input.reset()
        notices: list[str] = []
        if holds:
            while self.recorder.notices:
                notices.append(printable(self.recorder.notices.pop(0), limit=300))
                self.message = Message(notices[-1], "note")
        return Played(tuple(moves), tuple(notices))

    def _stop(self, error: OSError | ValueError) -> None:
        """The recording cannot be written: play no further."""
        self.write_error = error
        self.input.reset()
        self.game.stop()


def entering_view(move_input: MoveInput, mode: InputMode, profile: HoldProfile, *, releases_seen: bool,
                  last_key_at: float | None, now: float) -> HoldView | None:
    """The move being entered as shown: its level, gauge fill and hold ms (None: none).

    In a mode that times holds, without release events a hold with no autorepeat yet is a
    tap (level 1) and a hold shows no more than one repeat period past its last key event
    (`last_key_at`), so the gauge never shows a level the move will not get.
    """
    current = move_input.current()
    if current is None:
        return None
    if not mode.times_holds:
        return HoldView(current.key, current.level, float(current.level), current.elapsed_ms)
    return _timed_view(current, profile, releases_seen=releases_seen, last_key_at=last_key_at, now=now)


def _timed_view(current: ActiveHold, p: HoldProfile, *, releases_seen: bool, last_key_at: float | None,
                now: float) -> HoldView:
    shown_ms = current.elapsed_ms
    if not releases_seen:
        if current.repeats == 0:
            return HoldView(current.key, 1, 1 + 0.9 * min(1.0, shown_ms / p.tap_ms), shown_ms)
        if last_key_at is not None:
            started = now - current.elapsed_ms / 1000
            shown_ms = min(shown_ms, (last_key_at - started) * 1000 + p.repeat_period_ms)
    level = p.level_for(shown_ms)
    if shown_ms < p.tap_ms:
        fill = 1 + shown_ms / p.tap_ms
    else:
        fill = 2 + (shown_ms - p.tap_ms) / p.ms_per_level
    return HoldView(current.key, level, min(fill, level + 0.999, float(p.levels)), shown_ms)


def session_header(world: World, *, options: PlayOptions, seed: int, app_version: str,
                   study: StudyTag | None = None) -> SessionHeader:
    """The header of a session of `world` played with `options` (its time is set when the file is made)."""
    profile = options.profile or HoldProfile(levels=world.levels)
    return SessionHeader(world=world, player=options.player, created=datetime.now().astimezone(), seed=seed,
                         input=options.mode.header(profile), app_version=app_version, study=study)


def new_session(world: World, *, out: str | Path, seed: int, options: PlayOptions = PlayOptions(),
                clock: Clock = time.monotonic, app_version: str, study: StudyTag | None = None,
                first_episode: int = 0) -> PlaySession:
    """A session of `world` recording to a new file in `out` (made at the first move; its header
    tagged with `study`, if given), its episodes numbered from `first_episode`."""
    header = session_header(world, options=options, seed=seed, app_version=app_version, study=study)
    game = Game(world, seed=seed, sink=(recorder := SessionRecorder(out, header)), first_episode=first_episode)
    return PlaySession(game, recorder, options, clock=clock)
