"""Turn key events into move intents: a direction and a carefulness level.

A terminal reports key presses and autorepeats, not releases (docs/playing.md), so the length of
a hold is inferred from the autorepeat rhythm: a press starts a hold, autorepeats of the same key
extend it, silence longer than the release timeout ends it and another key ends it at once. Where
the front end does report releases (a terminal speaking kitty's keyboard protocol, a browser's
keyup), a release ends the hold exactly.

Three input modes produce the same `Hold` (key, level, hold_ms, exact), so the play session
(`irl_core.play.session`) can use any of them through the `MoveInput` protocol; the registry of
modes is `irl_core.play.input_modes`:

| mode     | class          | how a level is chosen                                        |
|----------|----------------|--------------------------------------------------------------|
| `hold`   | `HoldDetector` | hold the arrow; the level rises with the hold time           |
| `tap`    | `TapCounter`   | tap the same arrow k times quickly for level k (`modes`)     |
| `digits` | `DigitsInput`  | type the level, then the arrow (`modes`)                     |

Time: every class takes an injectable `clock` (seconds, like `time.monotonic`) so the tests
drive time by hand, and every key event can be given the time it happened (`at`, on that clock).
A front end passes the time the key reached it, not the time it got round to handling it: a
stalled app (a slow redraw, a garbage collection, a busy machine) handles a queue of autorepeats
at once, and timed by handling they would look like a silence (the hold ended) followed by a
burst (a new hold). Nothing here imports Textual.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

DIRECTIONS: tuple[str, ...] = ("up", "right", "down", "left")
"""The keys that carry a move, as every front end names them (Textual's names) (the order of `irl_core`'s directions)."""

DIGITS: tuple[str, ...] = tuple("0123456789")

TAP_MS = 500.0
"""Holds shorter than this are level 1, in the terminal and the browser alike (`HoldProfile.tap_ms`):
a legacy terminal cannot see a hold shorter than its keyboard's autorepeat delay (500 ms is the
common default), so the browser, which times any hold, uses the scale the terminal can measure,
and a study that has both pools one measure of care."""

MS_PER_LEVEL = 150.0
"""Each further 150 ms of hold is one level more, in both front ends (`HoldProfile.ms_per_level`)."""

SHORTEST_AUTOREPEAT_DELAY_MS = 150.0
"""No keyboard starts repeating sooner after a press (the calibration accepts no shorter delay)."""

Clock = Callable[[], float]
"""Returns the current time in seconds (monotonic)."""


@dataclass(frozen=True)
class HoldProfile:
    """The keyboard's autorepeat timing and the level scale.

    Levels count from `tap_ms` T, one level per `ms_per_level` m, up to `levels` L: level = 1
    when hold_ms < T (it looks like a tap), else min(L, 2 + floor((hold_ms - T) / m)). The scale
    is the same in both front ends whatever the keyboard (`TAP_MS`, `MS_PER_LEVEL`; a study file
    may choose another); calibration changes only the timing of the inference (D, the period).
    With the defaults (T = 500, m = 150, L = 14):

    | hold_ms          | level            |
    |------------------|------------------|
    | 0 .. 499         | 1                |
    | 500 .. 649       | 2                |
    | 650 .. 799       | 3                |
    | 1400 .. 1549     | 8                |
    | 2150 .. 2299     | 13               |
    | 2300 and longer  | 14 (capped at L) |

    The release timeout (the silence that ends a hold when no release event comes):

    | state                  | timeout                                                  |
    |------------------------|----------------------------------------------------------|
    | no repeat seen yet     | D + `first_repeat_margin_ms`: the wait before a tap is a |
    |                        | move. Uncalibrated 200 (covers X11's 660 ms default      |
    |                        | delay with the assumed 500 ms); calibrated, the margin   |
    |                        | `Calibration` sets from the measured rhythm and spread   |
    | after repeats started  | max(`min_repeat_timeout_ms` (60), 3 repeat periods); 60  |
    |                        | ms keeps a fast (10 ms) repeat from ending on jitter     |

    `earliest_repeat_ms`: the same arrow again sooner than this after the press, with no
    repeat yet, cannot be an autorepeat, so it is a second press (a second move). Uncalibrated,
    `SHORTEST_AUTOREPEAT_DELAY_MS` (the delay is not known, so only what no keyboard repeats
    that fast is sure); calibrated, D minus the same margin.
    """

    initial_delay_ms: float = 500.0
    repeat_period_ms: float = 33.0
    ms_per_level: float = MS_PER_LEVEL
    tap_ms: float = TAP_MS
    levels: int = 14
    calibrated: bool = False
    first_repeat_margin_ms: float = 200.0
    earliest_repeat_ms: float = SHORTEST_AUTOREPEAT_DELAY_MS
    repeat_timeout_periods: float = 3.0
    min_repeat_timeout_ms: float = 60.0

    def __post_init__(self) -> None:
        if self.levels < 1:
            raise ValueError(f"levels must be at least 1, got {self.levels}")
        for name in ("initial_delay_ms", "repeat_period_ms", "ms_per_level", "tap_ms"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")

    @property
    def first_repeat_timeout_ms(self) -> float:
        """Silence after the press, with no repeat yet, that ends a hold (a tap)."""
        return self.initial_delay_ms + self.first_repeat_margin_ms

    def repeat_timeout_ms(self, period_ms: float | None = None) -> float:
        """Silence after a repeat that ends a hold, for a repeat period (default: the profile's)."""
        period = self.repeat_period_ms if period_ms is None else period_ms
        return max(self.min_repeat_timeout_ms, self.repeat_timeout_periods * period)

    def level_for(self, hold_ms: float) -> int:
        """The carefulness level a hold of `hold_ms` milliseconds gives (see the class table)."""
        if hold_ms < self.tap_ms:
            return 1
        # The epsilon keeps a hold of exactly level k's start, T + (k - 2) m, at level k when T and m are
        # not integers.
        steps = math.floor((hold_ms - self.tap_ms) / self.ms_per_level + 1e-9)
        return min(self.levels, 2 + steps)

    def to_header(self) -> dict[str, object]:
        """The timing profile for the session header's `"input"` object."""
        return {
            "initial_delay_ms": self.initial_delay_ms,
            "repeat_period_ms": self.repeat_period_ms,
            "ms_per_level": self.ms_per_level,
            "tap_ms": self.tap_ms,
            "calibrated": self.calibrated,
            "tap_wait_ms": self.first_repeat_timeout_ms,
            "second_press_within_ms": self.earliest_repeat_ms,
        }


@dataclass(frozen=True)
class Hold:
    """A finished move intent, the same in every input mode.

    Attributes:
        key: the direction key ("up", "right", "down" or "left").
        hold_ms: hold mode: the hold's length (measured with a release, else inferred);
            tap mode: first tap to last tap; digits mode: first key to the arrow.
        level: the carefulness level, 1..levels.
        exact: True when a key-release event measured `hold_ms`.
        started: clock time (seconds) of the move's first key event.
        repeats: key events after the first (autorepeats, extra taps; 0 in digits mode).
    """

    key: str
    hold_ms: float
    level: int
    exact: bool
    started: float
    repeats: int


@dataclass(frozen=True)
class ActiveHold:
    """A move still being entered, for the live gauge.

    Attributes:
        key: the direction key, or None in digits mode before the arrow.
        elapsed_ms: time since the move's first key event.
        level: the level the move would have if it ended now.
        repeats: key events after the first.
    """

    key: str | None
    elapsed_ms: float
    level: int
    repeats: int


class MoveInput(Protocol):
    """What the play session needs from an input mode.

    Feed it the keys in `keys` with `press`, every key release with `release`, each with the
    time it happened (`at`; default: the clock now), and call `poll` when `deadline` passes (a
    timer set for that time) once every key event before it has been fed. Each call returns the
    moves it finished. `reset` drops the move being entered; `cancel` drops it and also ignores
    the autorepeats of its key, which may still be held.
    """

    mode: str
    keys: frozenset[str]

    def press(self, key: str, *, repeat: bool | None = None, at: float | None = None) -> list[Hold]: ...

    def release(self, key: str, *, at: float | None = None) -> list[Hold]: ...

    def poll(self, *, at: float | None = None) -> list[Hold]: ...

    def deadline(self) -> float | None: ...

    def current(self) -> ActiveHold | None: ...

    def reset(self) -> None: ...

    def cancel(self) -> None: ...

    def header(self) -> dict[str, object]: ...


def check_key(key: str, keys: frozenset[str]) -> None:
    if key not in keys:
        raise ValueError(f"this input does not take {key!r}; it takes {sorted(keys)}")


@dataclass
class PendingHold:
    key: str
    started: float
    last: float
    repeats: int = 0
    first_repeat: float | None = None
    tail_pace_ms: float | None = None
    """Set on a hold that began on the key of a hold just ended by a silence: the same key again
    sooner than this (autorepeat pace) shows this 'press' was a late repeat of that hold."""


class SilenceEnded:
    """What the hold detector and the tap counter share: one pending move that a silence ends.

    Subclasses say when (`_deadline`) and make the move (`_end`, which clears `_pending`).
    """

    _pending: PendingHold | None
    _clock: Clock

    def poll(self, *, at: float | None = None) -> list[Hold]:
        """End the pending move if the silence since its last key event reached the deadline by
        `at` (default: now).

        The caller must have fed every key event that happened before `at`: a poll run while
        such events still wait in a queue would end a move those events extend (the play session
        polls only when the front end says none waits, `PlaySession.tick`).
        """
        pending = self._pending
        if pending is None or self._now(at) < self._deadline(pending):
            return []
        return [self._end(pending)]

    def _now(self, at: float | None) -> float:
        """The time of a key event: `at` when the caller knows it, else the clock now."""
        return self._clock() if at is None else at

    def deadline(self) -> float | None:
        """Clock time at which `poll` ends the pending move (None when there is none)."""
        return None if self._pending is None else self._deadline(self._pending)

    def _deadline(self, pending: PendingHold) -> float:
        raise NotImplementedError

    def _end(self, pending: PendingHold) -> Hold:
        raise NotImplementedError


class HoldDetector(SilenceEnded):
    """Hold mode: the level grows with how long an arrow is held.

    `press(key, repeat=...)`: `repeat` is None when the terminal cannot tell a press from an
    autorepeat (legacy input: the same key again extends the hold unless the release timeout has
    passed, or it came before any autorepeat could), True for an explicit kitty repeat (extends
    the hold; a repeat never starts one, as it is the tail of a hold already committed) and False
    for an explicit press (a new hold even on the same key).

    A second tap of the held arrow: with no repeat yet, the same arrow sooner than the profile's
    `earliest_repeat_ms` after the press is a second press. The first is then a tap (level 1,
    committed at once) and the second starts a hold of its own, so a participant tapping an
    arrow twice makes two moves instead of one silently merged into a hold. Once repeats have
    come, the same arrow always extends the hold: the key is down, and a release and press again
    within the repeat timeout (about 3 periods, 100 ms) cannot be told from repeats that a busy
    machine delivered late or bunched, so the rhythm says nothing safe there.

    The inferred length of a hold that saw repeats is the last repeat's time since the press plus
    half a repeat period: the release fell somewhere in the period after the last repeat (or a
    further repeat would have come), so the midpoint is off by at most half a period. The period
    is the hold's own mean repeat gap once two repeats were seen, else the profile's. A hold
    with no repeat is a tap: its length cannot be inferred and is reported as 0.0 (level 1).

    A delivery gap (a loaded machine, an SSH hop, tmux holding keys back for 100-400 ms) ends a
    hold by the silence while the key is still down, and its repeats then arrive again. They are
    the tail of the hold already played, never moves: after a hold ended by a silence, a 'press'
    of the same key followed by the same key at autorepeat pace (sooner than the hold's repeat
    timeout and `earliest_repeat_ms`, faster than a person taps) was a late repeat, so it and
    every repeat after it are dropped as after `cancel`, until the key has been silent again (and
    after a further gap, the same again). A press of the same key then held (its first repeat
    after the keyboard's delay) or tapped is a move of its own; so is a lone late repeat with
    nothing after it, which cannot be told from a tap.
    """

    mode = "hold"

    def __init__(self, profile: HoldProfile, *, clock: Clock = time.monotonic,
                 keys: frozenset[str] = frozenset(DIRECTIONS)) -> None:
        self.profile = profile
        self._clock = clock
        # The keys whose holds it times: the arrows in play, the launch keys of a reach (`irl_core.play.reach_session`).
        self.keys = keys
        self._pending: PendingHold | None = None
        self._cancelled: PendingHold | None = None
        self._tail: PendingHold | None = None

    def press(self, key: str, *, repeat: bool | None = None, at: float | None = None) -> list[Hold]:
        """A key press or autorepeat of `key` at time `at` (default: now); returns the hold it ended, if any."""
        check_key(key, self.keys)
        now = self._now(at)
        cancelled, self._cancelled = self._cancelled, None
        if cancelled is not None and self._continues(cancelled, key, repeat, now):
            self._extend(cancelled, now)
            self._cancelled = cancelled
            return []
        if cancelled is not None:
            self._tail = cancelled
        done: list[Hold] = []
        pending = self._pending
        if pending is not None and self._is_late_repeat(pending, key, repeat, now):
            self._drop_tail(pending, now)
            return done
        if pending is not None and self._continues(pending, key, repeat, now):
            self._extend(pending, now)
            return done
        if pending is not None:
            done.append(self._infer(pending))
            self._pending = None
            if pending.key == key and now >= self._deadline(pending):
                # Its silence had ended it and only the tick that says so came late (a busy machine): what
                # follows may be its late repeats, as after `_end`, not presses of their own.
                self._tail = pending if pending.repeats > 0 or pending.tail_pace_ms is not None else None
        if not repeat:
            self._pending = PendingHold(key=key, started=now, last=now, tail_pace_ms=self._tail_pace_ms(key, repeat))
        self._tail = None
        return done

    def _tail_pace_ms(self, key: str, repeat: bool | None) -> float | None:
        """The autorepeat pace of the hold a silence just ended on `key` (None: no such hold)."""
        tail = self._tail
        if tail is None or tail.key != key or repeat is not None:
            return None
        return min(self.profile.repeat_timeout_ms(self._period_ms(tail)), self.profile.earliest_repeat_ms)

    def _is_late_repeat(self, pending: PendingHold, key: str, repeat: bool | None, now: float) -> bool:
        """Whether `key` at `now` shows the `pending` 'press' was a repeat held back by a delivery gap."""
        pace = pending.tail_pace_ms
        return (pace is not None and repeat is None and pending.key == key and pending.repeats == 0
                and (now - pending.last) * 1000.0 < pace)

    def _drop_tail(self, pending: PendingHold, now: float) -> None:
        """Drop the late repeats of a hold already played, as `cancel` drops a held key's repeats."""
        self._pending = None
        self._extend(pending, now)
        self._cancelled = pending

    def release(self, key: str, *, at: float | None = None) -> list[Hold]:
        """A key-release event at time `at` (default: now): ends the hold on `key` exactly
        (releases of other keys are ignored).

        A release wins over inference even after the timeout, as long as `poll` has not yet
        ended the hold: it is a measurement, the timeout only a guess.
        """
        if self._cancelled is not None and self._cancelled.key == key:
            self._cancelled = None
        if self._tail is not None and self._tail.key == key:
            self._tail = None
        pending = self._pending
        if pending is None or pending.key != key:
            return []
        self._pending = None
        hold_ms = (self._now(at) - pending.started) * 1000.0
        return [self._hold(pending, hold_ms, exact=True)]

    def current(self) -> ActiveHold | None:
        """The hold in progress, with the level it would have if released now."""
        pending = self._pending
        if pending is None:
            return None
        elapsed_ms = (self._clock() - pending.started) * 1000.0
        return ActiveHold(
            key=pending.key,
            elapsed_ms=elapsed_ms,
            level=self.profile.level_for(elapsed_ms),
            repeats=pending.repeats,
        )

    def reset(self) -> None:
        """Drop the hold in progress without committing it."""
        self._pending = None
        self._cancelled = None
        self._tail = None

    def cancel(self) -> None:
        """Drop the hold in progress, and ignore its key until the player lets go of it.

        A legacy terminal keeps autorepeating a key that is still down, and those repeats would
        start a new hold the player never pressed for. So until the key has been silent for the
        release timeout the hold had (`deadline` of the dropped hold, extended by each ignored
        repeat as a hold would be), or a release or explicit press of it arrives (kitty), or
        another key is pressed (a keyboard repeats only the newest key), the same key is
        ignored. A press too soon for an autorepeat is, as in a hold, a new press.
        """
        if self._pending is not None:
            self._cancelled, self._pending = self._pending, None

    def header(self) -> dict[str, object]:
        """The session header's `"input"` object."""
        return {"mode": self.mode, **self.profile.to_header()}

    def _continues(self, held: PendingHold, key: str, repeat: bool | None, now: float) -> bool:
        """Whether `key` at `now` is an autorepeat of the `held` key (not a press of its own)."""
        if held.key != key or repeat is False:
            return False
        return bool(repeat) or (now < self._deadline(held) and not self._too_soon_for_a_repeat(held, now))

    def _extend(self, pending: PendingHold, now: float) -> None:
        pending.repeats += 1
        if pending.first_repeat is None:
            pending.first_repeat = now
        pending.last = now

    def _too_soon_for_a_repeat(self, pending: PendingHold, now: float) -> bool:
        """Whether the same arrow at `now` came before any first autorepeat could (a second press)."""
        return pending.repeats == 0 and (now - pending.started) * 1000.0 < self.profile.earliest_repeat_ms

    def _period_ms(self, pending: PendingHold) -> float:
        if pending.repeats >= 2 and pending.first_repeat is not None:
            return (pending.last - pending.first_repeat) * 1000.0 / (pending.repeats - 1)
        return self.profile.repeat_period_ms

    def _deadline(self, pending: PendingHold) -> float:
        if pending.repeats == 0:
            timeout_ms = self.profile.first_repeat_timeout_ms
        else:
            timeout_ms = self.profile.repeat_timeout_ms(self._period_ms(pending))
        return pending.last + timeout_ms / 1000.0

    def _end(self, pending: PendingHold) -> Hold:
        """The hold ended by the release timeout, its length inferred (its key may still be down)."""
        self._pending = None
        self._tail = pending if pending.repeats > 0 or pending.tail_pace_ms is not None else None
        return self._infer(pending)

    def _infer(self, pending: PendingHold) -> Hold:
        if pending.repeats == 0:
            hold_ms = 0.0
        else:
            hold_ms = (pending.last - pending.started) * 1000.0 + self._period_ms(pending) / 2
        return self._hold(pending, hold_ms, exact=False)

    def _hold(self, pending: PendingHold, hold_ms: float, *, exact: bool) -> Hold:
        return Hold(
            key=pending.key,
            hold_ms=hold_ms,
            level=self.profile.level_for(hold_ms),
            exact=exact,
            started=pending.started,
            repeats=pending.repeats,
        )
