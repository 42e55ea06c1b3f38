"""One reach session, for any front end: the aim, the hold that times the reach, the launch and its recording.

A reach world (docs/reach.md) is played one trial at a time. The participant moves an **aim** over the
field, then holds a key (space or Enter) for the reach's **duration** and lets go to launch it. While the
key is held a ring around the aim shows the endpoint's spread for the hold so far, by the world's spread
law: it shrinks the longer they hold. On release the reach is launched:

- a duration outside the world's ``min_ms`` to ``max_ms`` is **refused** with a word to the participant
  (`too_quick_words`, `too_slow_words`) and the same trial is asked again; nothing is recorded;
- otherwise (``noise = "simulated"``) the endpoint is the aim plus a normal scatter of the law's sd on each
  axis, drawn from the session's seeded generator; it scores the circles holding it less the time cost,
  and the trial is written at once as a step line (docs/reach.md), synced, through the session recorder
  (`irl_core.recordings.writer.SessionRecorder`: a new file at the first trial, header first, whole lines
  only, a deleted folder recreated);
- after the set number of trials (the block) the session is done.

With ``noise = "own"`` the front end measures the reach itself (a browser's real pointer) and hands it over
with `launch_own`; the hold keys do nothing there.

Time is as in `irl_core.play.session`: every call takes the time its key event happened (`at`, seconds on
the session's `clock`). A front end that sees the key come up (a browser's keyup, a kitty terminal) calls
`release`, and the duration is exact (``hold_exact: true``). A legacy terminal sends only the press and its
autorepeats: the hold is inferred from them as `irl_core.play.hold.HoldDetector` infers a move's (the last
repeat plus half a period; a hold with no repeat reads as 0 ms, too quick) and recorded with
``hold_exact: false``; such a front end calls `tick` at about 30 Hz while `entering()`.

The aim starts at the centre of the circle worth the most points (the field's centre when none is worth
any): the place a player who takes no care aims at, so every move away from it is the participant's own
choice of care, and a participant who does nothing records no care rather than some made up by the screen.
After a trial the aim stays where it was (a pointer stays where it was left): the participant re-aims only
when they want to.

The words the participant reads are here (`REACH_TITLE`, `REACH_INTRO`, `result_words`, the refusals), the
same in the terminal and the browser. No front end is imported here.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from irl_core.play.hold import Clock, Hold, HoldDetector, HoldProfile
from irl_core.play.session import Message
from irl_core.recordings.reach_lines import ReachHeader, ReachStep
from irl_core.recordings.writer import SessionRecorder
from irl_core.support.safe_text import printable
from irl_core.worlds.reach import ReachWorld, endpoint_of

LAUNCH_KEYS = frozenset({"space", "enter"})
"""The keys held for a reach's duration (Textual's names; a browser maps " " and "Enter" to them)."""

DEFAULT_TRIALS = 20
"""Trials in a block when the front end does not say."""

FIRST_REPEAT_MARGIN_MS = 1000.0
"""Without releases, how long past the keyboard's assumed autorepeat delay (500 ms) a press waits for its first
repeat before it counts as a tap. Play waits 200 ms, as a tap there is a move; a reach's tap is refused anyway,
so the wait costs nothing, and a first repeat that a slow keyboard (X11's 660 ms) or a busy machine makes late
still extends the hold from its press instead of splitting it into refused taps."""

LATE_REPEAT_S = 0.5
"""A lone autorepeat this soon after the end of the hold that launched a reach is that hold's tail (see
`ReachSession._tail_of_last_launch`)."""

REACH_TITLE = "Reach"
REACH_INTRO = ("Aim with the arrow keys, then hold space for as long as the reach should take and let go. "
               "The ring is where the reach may land: the longer you hold, the smaller it gets, "
               "but time costs points.")
REACH_INTRO_OWN = ("Press on the start, move to where you want to land and let go. The reach counts from "
                   "leaving the start to letting go: slower lands closer, but time costs points.")


def too_quick_words(world: ReachWorld, *, inferred: bool) -> str:
    """Why a reach shorter than ``min_ms`` was refused, and what to do (one line)."""
    words = f"Too quick: hold longer (at least {world.min_ms:g} ms). Try again."
    if inferred:
        # A legacy terminal times a hold only once the key starts repeating.
        words += " This terminal sees a hold only once the key repeats."
    return words


def too_slow_words(world: ReachWorld) -> str:
    """Why a reach longer than ``max_ms`` was refused, and what to do (one line)."""
    return f"Too slow: let go sooner (at most {world.max_ms:g} ms). Try again."


def result_words(step: ReachStep) -> str:
    """What the participant is told after a trial: where it landed, its points and the time it took."""
    where = " + ".join(step.regions) if step.regions else "no circle"
    return f"Landed in {where}: {step.reward:+.1f} points ({step.duration_ms:.0f} ms)."


@dataclass(frozen=True)
class ReachOptions:
    """How a reach session plays: its player's name, its block of trials, its title.

    Attributes:
        player: the name recorded in the header.
        trials: how many trials the block has (at least 1).
        heading: the session's title.
        command: what a front end names when its window is too small to play in.
    """

    player: str = "player"
    trials: int = DEFAULT_TRIALS
    heading: str = "careful play"
    command: str = "careful play"

    def __post_init__(self) -> None:
        if self.trials < 1:
            raise ValueError(f"a block has at least 1 trial, not {self.trials}")


@dataclass(frozen=True)
class HoldingView:
    """The reach being timed: `held_ms` so far (as it will count: without releases, no more than one repeat
    period past the last autorepeat), `ring_sd` the endpoint's sd for it (field units: what the ring draws),
    and `within`: "short" below ``min_ms``, "ok", "long" above ``max_ms``."""

    held_ms: float
    ring_sd: float
    within: str


@dataclass(frozen=True)
class ReachView:
    """What a front end draws, as it is now.

    Attributes:
        world: the reach world (the field, its circles, the start).
        aim: where the next reach is aimed (field units).
        trial: the trial being asked (1-based; the last trial's number once done).
        trials: the block's trials.
        done: every trial is recorded (or a write failure stopped the session).
        holding: the reach being timed (None: no key held).
        last: the last recorded trial (None before any): its endpoint, regions, reward.
        score: the rewards so far, added up.
        message: the line for the participant (a refusal is kind "warn").
        recording: the file being written, or the folder (ending in a separator) before it is made.
    """

    world: ReachWorld
    aim: tuple[float, float]
    trial: int
    trials: int
    done: bool
    holding: HoldingView | None
    last: ReachStep | None
    score: float
    message: Message
    recording: str


def starting_aim(world: ReachWorld) -> tuple[float, float]:
    """The centre of the circle worth the most points (the first such), or the field's centre if none is worth any."""
    best = max(world.regions, key=lambda region: region.points)
    if best.points > 0:
        return best.centre
    return world.field[0] / 2, world.field[1] / 2


class ReachSession:
    """One block of reaches in a reach world, recorded as it goes. Build one with `new_reach_session`.

    Calls: `move_aim`, `press`/`release`/`tick` (the hold), `launch_own` (``noise = "own"``), `cancel_hold`,
    `quit`; draw `view()` after each. `keys` are the hold keys.
    """

    def __init__(self, world: ReachWorld, recorder: SessionRecorder, *, seed: int,
                 options: ReachOptions = ReachOptions(), clock: Clock = time.monotonic,
                 profile: HoldProfile | None = None) -> None:
        self.world = world
        self.recorder = recorder
        self.options = options
        self.clock = clock
        self.profile = profile or HoldProfile(first_repeat_margin_ms=FIRST_REPEAT_MARGIN_MS)
        self.rng = np.random.default_rng(seed)
        self.input = HoldDetector(self.profile, clock=clock, keys=LAUNCH_KEYS)
        self.aim: tuple[float, float] = starting_aim(world)
        self.steps: list[ReachStep] = []
        self.score = 0.0
        self.message = Message()
        self.write_error: OSError | ValueError | None = None
        self.releases_seen = False
        self._last_key_at: float | None = None
        self._last_hold_end: float | None = None

    @property
    def keys(self) -> frozenset[str]:
        return LAUNCH_KEYS

    @property
    def done(self) -> bool:
        return len(self.steps) >= self.options.trials or self.write_error is not None

    @property
    def aim_step(self) -> float:
        """A sensible step for one press of an arrow (field units): an eighth of the smallest circle's radius."""
        return min(region.radius for region in self.world.regions) / 8

    # ------------------------------------------------------------------ the aim

    def move_aim(self, dx: float, dy: float) -> tuple[float, float]:
        """Move the aim by (dx, dy) field units, kept inside the field; ignored while a reach is being timed
        (the aim is set before the reach) and once done. Returns the aim."""
        if not self.done and self.input.current() is None:
            width, height = self.world.field
            self.aim = (min(max(self.aim[0] + dx, 0.0), width), min(max(self.aim[1] + dy, 0.0), height))
        return self.aim

    # ------------------------------------------------------------------ the hold

    def press(self, key: str, *, at: float | None = None, repeat: bool | None = None) -> ReachStep | None:
        """A hold key went down or autorepeated at `at` (`repeat` as `PlaySession.press`). Returns the trial it
        recorded, if a hold it ended did (another key ends a hold at once)."""
        if key not in self.keys or self.done or self.world.noise == "own":
            return None
        at = self.clock() if at is None else at
        self._last_key_at = at
        return self._launch(self.input.press(key, repeat=repeat, at=at))

    def release(self, key: str, *, at: float | None = None) -> ReachStep | None:
        """A hold key came up at `at`: the reach is launched, its duration exact. Returns the trial recorded."""
        if key not in self.keys or self.done:
            return None
        self.releases_seen = True
        return self._launch(self.input.release(key, at=at))

    def tick(self, *, until: float | None = None, keys_waiting: bool = False) -> ReachStep | None:
        """Time passed: a hold whose silence ran out by `until` ends and launches (never while `keys_waiting`:
        key events still queued in the front end mean the silence is none)."""
        if keys_waiting or self.done:
            return None
        return self._launch(self.input.poll(at=until))

    def entering(self) -> bool:
        """A reach is being timed, or waits for its silence: a front end keeps calling `tick`."""
        return self.input.current() is not None or self.input.deadline() is not None

    def deadline(self) -> float | None:
        """When the silence ends the hold being timed (clock seconds), if nothing comes first."""
        return self.input.deadline()

    def cancel_hold(self, why: str) -> bool:
        """Drop the reach being timed (focus lost, the window shrank): its key is ignored until let go.
        Returns whether there was one; the message says `why`."""
        if self.input.current() is None:
            return False
        self.input.cancel()
        self.message = Message(f"Reach cancelled ({why}).", "warn")
        return True

    def ring_sd(self, at: float | None = None) -> float | None:
        """The endpoint's sd per axis (field units) if the reach were launched at `at` (default: now), by the
        spread law at the aim, its duration held within ``min_ms`` to ``max_ms`` (a shorter or longer hold is
        refused, so the ring shows the nearest reach allowed); None when no key is held."""
        held = self._held_ms(self.clock() if at is None else at)
        if held is None:
            return None
        return float(self.world.sd(self.aim, min(max(held, self.world.min_ms), self.world.max_ms)))

    # ------------------------------------------------------------------ launching

    def launch_own(self, endpoint: tuple[float, float], duration_ms: float, *,
                   aim: tuple[float, float] | None = None) -> ReachStep | None:
        """A reach the front end measured itself (``noise = "own"``: a browser's real pointer), timed exactly:
        where it ended and how long it took from leaving the start. `aim` defaults to the session's aim. A
        duration outside the limits is refused (returns None, the message says why); an endpoint outside the
        field is kept to the field's edge.

        Raises:
            ValueError: the world's noise is simulated (its endpoint is drawn here, from a hold), or the
                endpoint or duration is not a finite number.
        """
        if self.world.noise != "own":
            raise ValueError("launch_own is for a world with noise = \"own\"; this one draws its endpoints")
        if not (np.all(np.isfinite(endpoint)) and np.isfinite(duration_ms)):
            raise ValueError(f"a reach's endpoint and duration must be finite numbers, not {endpoint}, {duration_ms}")
        if self.done or not self._allowed(round(float(duration_ms), 3), inferred=False):
            return None
        width, height = self.world.field
        landed = (min(max(float(endpoint[0]), 0.0), width), min(max(float(endpoint[1]), 0.0), height))
        return self._record(aim or self.aim, landed, round(float(duration_ms), 3), exact=True)

    def _launch(self, holds: list[Hold]) -> ReachStep | None:
        recorded = None
        for hold in holds:
            if self.done:
                break
            if self._tail_of_last_launch(hold):
                continue
            # To the microsecond: a clock's float arithmetic makes a 150 ms hold 149.99999999997 ms.
            duration_ms = round(hold.hold_ms, 3)
            if self._allowed(duration_ms, inferred=not hold.exact):
                end = endpoint_of(self.world, self.aim, duration_ms, self.rng)
                recorded = self._record(self.aim, (float(end[0]), float(end[1])), duration_ms, exact=hold.exact)
        return recorded

    def _tail_of_last_launch(self, hold: Hold) -> bool:
        """Whether `hold` is a lone late autorepeat of the reach just launched, not a press of its own.

        Without releases a reach is launched by the silence after its autorepeats; on a busy machine that
        silence can be a delivery gap with the key still down, and a lone repeat that comes after it reads
        as a tap. It is dropped without a word: called too quick, it would hide the reach's result."""
        last, self._last_hold_end = self._last_hold_end, None if hold.exact else hold.started + hold.hold_ms / 1000
        return (not hold.exact and hold.repeats == 0 and last is not None
                and hold.started - last < LATE_REPEAT_S)

    def _allowed(self, duration_ms: float, *, inferred: bool) -> bool:
        """Whether a reach of `duration_ms` may be launched; if not, the message says why (nothing is recorded)."""
        if duration_ms < self.world.min_ms:
            self.message = Message(too_quick_words(self.world, inferred=inferred), "warn")
            return False
        if duration_ms > self.world.max_ms:
            self.message = Message(too_slow_words(self.world), "warn")
            return False
        return True

    def _record(self, aim: tuple[float, float], endpoint: tuple[float, float], duration_ms: float, *,
                exact: bool) -> ReachStep | None:
        reward = self.world.score_of(endpoint, duration_ms)
        step = ReachStep(episode=len(self.steps), t=0, aim=(float(aim[0]), float(aim[1])), duration_ms=duration_ms,
                         endpoint=endpoint, regions=tuple(self.world.regions_holding(endpoint)), reward=reward,
                         score=self.score + reward, hold_exact=exact)
        try:
            self.recorder.write_reach(step)
        except (OSError, ValueError) as exc:
            self.write_error = exc
            self.input.reset()
            self.message = Message(f"The trial could not be written: {printable(str(exc), limit=200)}", "warn")
            return None
        self.steps.append(step)
        self.score = step.score
        self.message = Message(result_words(step), "note")
        while self.recorder.notices:
            self.message = Message(printable(self.recorder.notices.pop(0), limit=300), "note")
        if self.done:
            self.quit()
        return step

    # ------------------------------------------------------------------ what is shown

    def _held_ms(self, now: float) -> float | None:
        """The hold so far as it will count (None: none). Without releases, a hold that has repeated shows no
        more than one repeat period past its last key event, as the play session's gauge does."""
        current = self.input.current()
        if current is None:
            return None
        held = current.elapsed_ms
        if not self.releases_seen and current.repeats > 0 and self._last_key_at is not None:
            started = now - current.elapsed_ms / 1000
            held = min(held, (self._last_key_at - started) * 1000 + self.profile.repeat_period_ms)
        return held

    def view(self) -> ReachView:
        now = self.clock()
        held = None if self.done else self._held_ms(now)
        holding = None
        if held is not None:
            within = "short" if held < self.world.min_ms else "long" if held > self.world.max_ms else "ok"
            holding = HoldingView(held_ms=held, ring_sd=self.ring_sd(now) or 0.0, within=within)
        path = self.recorder.path
        return ReachView(
            world=self.world, aim=self.aim, trial=min(len(self.steps) + 1, self.options.trials),
            trials=self.options.trials, done=self.done, holding=holding,
            last=self.steps[-1] if self.steps else None, score=self.score, message=self.message,
            recording=str(path) if path is not None else f"{self.recorder.folder}{os.sep}",
        )

    # ------------------------------------------------------------------ leaving

    def quit(self) -> None:
        """Close the file (safe to call more than once; a write failure is kept in `write_error`). A reach being
        timed is not a trial and is dropped."""
        self.input.reset()
        try:
            self.recorder.close()
        except (OSError, ValueError) as exc:
            self.write_error = self.write_error or exc


def reach_header(world: ReachWorld, *, player: str, seed: int, app_version: str) -> ReachHeader:
    """The header of a reach session (its time is set when the file is made, at the first trial)."""
    return ReachHeader(world=world, player=player, created=datetime.now().astimezone(), seed=seed,
                       app_version=app_version)


def new_reach_session(world: ReachWorld, *, out: str | Path, seed: int, app_version: str,
                      options: ReachOptions = ReachOptions(), clock: Clock = time.monotonic) -> ReachSession:
    """A reach session of `world` recording to a new file in `out` (made at the first trial)."""
    header = reach_header(world, player=options.player, seed=seed, app_version=app_version)
    return ReachSession(world, SessionRecorder(out, header), seed=seed, options=options, clock=clock)
