"""Turn key events into move intents: a direction and a carefulness level.

A terminal reports key presses and autorepeats, not releases (SPEC section 5), so the length of
a hold is inferred from the autorepeat rhythm: a press starts a hold, autorepeats of the same key
extend it, silence longer than the release timeout ends it and another key ends it at once. Where
the terminal does report releases (kitty's keyboard protocol, see `careful_tui.kitty`), a release
ends the hold exactly.

Three input modes produce the same `Hold` (key, level, hold_ms, exact), so the play screen can use
any of them through the `MoveInput` protocol:

| mode     | class          | how a level is chosen                                        |
|----------|----------------|--------------------------------------------------------------|
| `hold`   | `HoldDetector` | hold the arrow; the level rises with the hold time           |
| `tap`    | `TapCounter`   | tap the same arrow k times quickly for level k               |
| `digits` | `DigitsInput`  | type the level, then the arrow                               |

Nothing here imports Textual: every class takes an injectable `clock` (seconds, like
`time.monotonic`) so the tests drive time by hand.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol

DIRECTIONS: tuple[str, ...] = ("up", "right", "down", "left")
"""The keys that carry a move, as Textual names them (the order of `irl_core`'s directions)."""

DIGITS: tuple[str, ...] = tuple("0123456789")

Clock = Callable[[], float]
"""Returns the current time in seconds (monotonic)."""


@dataclass(frozen=True)
class HoldProfile:
    """The keyboard's autorepeat timing and the level scale built on it.

    Levels count from the autorepeat initial delay D, one level per `ms_per_level` m, up to
    `levels` L: level = 1 when hold_ms < D (it looks like a tap), else
    min(L, 2 + floor((hold_ms - D) / m)). With the defaults (D = 500, m = 150, L = 14):

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
    | no repeat seen yet     | D + `first_repeat_margin_ms` (200): covers X11's 660 ms  |
    |                        | default delay with the uncalibrated 500 ms profile, and  |
    |                        | scheduling jitter with a calibrated one                  |
    | after repeats started  | max(`min_repeat_timeout_ms` (60), 3 repeat periods); 60  |
    |                        | ms keeps a fast (10 ms) repeat from ending on jitter     |
    """

    initial_delay_ms: float = 500.0
    repeat_period_ms: float = 33.0
    ms_per_level: float = 150.0
    levels: int = 14
    calibrated: bool = False
    first_repeat_margin_ms: float = 200.0
    repeat_timeout_periods: float = 3.0
    min_repeat_timeout_ms: float = 60.0

    def __post_init__(self) -> None:
        if self.levels < 1:
            raise ValueError(f"levels must be at least 1, got {self.levels}")
        for name in ("initial_delay_ms", "repeat_period_ms", "ms_per_level"):
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
        if hold_ms < self.initial_delay_ms:
            return 1
        # The epsilon keeps level_for(hold_ms_for(k)) == k when D and m are not integers.
        steps = math.floor((hold_ms - self.initial_delay_ms) / self.ms_per_level + 1e-9)
        return min(self.levels, 2 + steps)

    def hold_ms_for(self, level: int) -> float:
        """The shortest hold, in milliseconds, that gives `level` (1..levels)."""
        if not 1 <= level <= self.levels:
            raise ValueError(f"level must be in 1..{self.levels}, got {level}")
        if level == 1:
            return 0.0
        return self.initial_delay_ms + (level - 2) * self.ms_per_level

    def to_header(self) -> dict[str, object]:
        """The timing profile for the session header's `"input"` object."""
        return {
            "initial_delay_ms": self.initial_delay_ms,
            "repeat_period_ms": self.repeat_period_ms,
            "ms_per_level": self.ms_per_level,
            "calibrated": self.calibrated,
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
    """What the play screen needs from an input mode.

    Feed it the keys in `keys` with `press`, every key release with `release`, and call `poll`
    when `deadline` passes (a timer set for that time). Each call returns the moves it finished.
    """

    mode: str
    keys: frozenset[str]

    def press(self, key: str, *, repeat: bool | None = None) -> list[Hold]: ...

    def release(self, key: str) -> list[Hold]: ...

    def poll(self) -> list[Hold]: ...

    def deadline(self) -> float | None: ...

    def current(self) -> ActiveHold | None: ...

    def reset(self) -> None: ...

    def header(self) -> dict[str, object]: ...


def _check_key(key: str, keys: frozenset[str]) -> None:
    if key not in keys:
        raise ValueError(f"this input does not take {key!r}; it takes {sorted(keys)}")


@dataclass
class _Pending:
    key: str
    started: float
    last: float
    repeats: int = 0
    first_repeat: float | None = None


class HoldDetector:
    """Hold mode: the level grows with how long an arrow is held.

    `press(key, repeat=...)`: `repeat` is None when the terminal cannot tell a press from an
    autorepeat (legacy input: the same key again extends the hold unless the release timeout has
    passed), True for an explicit kitty repeat (extends the hold; a repeat never starts one, as it
    is the tail of a hold already committed) and False for an explicit press (a new hold even on
    the same key).

    The inferred length of a hold that saw repeats is the last repeat's time since the press plus
    half a repeat period: the release fell somewhere in the period after the last repeat (or a
    further repeat would have come), so the midpoint is off by at most half a period. The period
    is the hold's own mean repeat gap once two repeats were seen, else the profile's. A hold
    with no repeat is a tap: its length cannot be inferred and is reported as 0.0 (level 1).
    """

    mode = "hold"
    keys = frozenset(DIRECTIONS)

    def __init__(self, profile: HoldProfile, *, clock: Clock = time.monotonic) -> None:
        self.profile = profile
        self._clock = clock
        self._pending: _Pending | None = None

    def press(self, key: str, *, repeat: bool | None = None) -> list[Hold]:
        """A key press or autorepeat of `key`; returns the hold it ended, if any."""
        _check_key(key, self.keys)
        now = self._clock()
        done: list[Hold] = []
        pending = self._pending
        if pending is not None and pending.key == key and repeat is not False:
            if repeat or now < self._deadline(pending):
                self._extend(pending, now)
                return done
        if pending is not None:
            done.append(self._infer(pending))
            self._pending = None
        if not repeat:
            self._pending = _Pending(key=key, started=now, last=now)
        return done

    def release(self, key: str) -> list[Hold]:
        """A key-release event: ends the hold on `key` exactly (releases of other keys are ignored).

        A release wins over inference even after the timeout, as long as `poll` has not yet
        ended the hold: it is a measurement, the timeout only a guess.
        """
        pending = self._pending
        if pending is None or pending.key != key:
            return []
        self._pending = None
        hold_ms = (self._clock() - pending.started) * 1000.0
        return [self._hold(pending, hold_ms, exact=True)]

    def poll(self) -> list[Hold]:
        """End the hold if the silence since its last key event reached the release timeout."""
        pending = self._pending
        if pending is None or self._clock() < self._deadline(pending):
            return []
        self._pending = None
        return [self._infer(pending)]

    def deadline(self) -> float | None:
        """Clock time at which `poll` ends the current hold (None when nothing is held)."""
        return None if self._pending is None else self._deadline(self._pending)

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

    def header(self) -> dict[str, object]:
        """The session header's `"input"` object."""
        return {"mode": self.mode, **self.profile.to_header()}

    def _extend(self, pending: _Pending, now: float) -> None:
        pending.repeats += 1
        if pending.first_repeat is None:
            pending.first_repeat = now
        pending.last = now

    def _period_ms(self, pending: _Pending) -> float:
        if pending.repeats >= 2 and pending.first_repeat is not None:
            return (pending.last - pending.first_repeat) * 1000.0 / (pending.repeats - 1)
        return self.profile.repeat_period_ms

    def _deadline(self, pending: _Pending) -> float:
        if pending.repeats == 0:
            timeout_ms = self.profile.first_repeat_timeout_ms
        else:
            timeout_ms = self.profile.repeat_timeout_ms(self._period_ms(pending))
        return pending.last + timeout_ms / 1000.0

    def _infer(self, pending: _Pending) -> Hold:
        if pending.repeats == 0:
            hold_ms = 0.0
        else:
            hold_ms = (pending.last - pending.started) * 1000.0 + self._period_ms(pending) / 2
        return self._hold(pending, hold_ms, exact=False)

    def _hold(self, pending: _Pending, hold_ms: float, *, exact: bool) -> Hold:
        return Hold(
            key=pending.key,
            hold_ms=hold_ms,
            level=self.profile.level_for(hold_ms),
            exact=exact,
            started=pending.started,
            repeats=pending.repeats,
        )


class TapCounter:
    """Tap mode (`--input tap`): tap the same arrow k times quickly for level k.

    A pause of `tap_window_ms` (default 400) after the last tap, or a different arrow, commits
    the move; taps beyond `levels` stay at the top level. Explicit kitty repeats
    (`repeat=True`) are not taps and are ignored; a legacy terminal cannot tell them apart, so
    holding an arrow there counts its autorepeats as taps.
    """

    mode = "tap"
    keys = frozenset(DIRECTIONS)

    def __init__(
        self,
        profile: HoldProfile,
        *,
        clock: Clock = time.monotonic,
        tap_window_ms: float = 400.0,
    ) -> None:
        self.profile = profile
        self.tap_window_ms = tap_window_ms
        self._clock = clock
        self._pending: _Pending | None = None

    def press(self, key: str, *, repeat: bool | None = None) -> list[Hold]:
        """A tap of `key`; returns the move it committed (a different arrow commits at once)."""
        _check_key(key, self.keys)
        if repeat:
            return []
        done = self.poll()
        now = self._clock()
        pending = self._pending
        if pending is not None and pending.key == key:
            pending.repeats += 1
            pending.last = now
            return done
        if pending is not None:
            done.append(self._commit(pending))
        self._pending = _Pending(key=key, started=now, last=now)
        return done

    def release(self, key: str) -> list[Hold]:
        """Releases carry no meaning in tap mode."""
        return []

    def poll(self) -> list[Hold]:
        """Commit the taps if the pause since the last one reached the tap window."""
        pending = self._pending
        if pending is None or self._clock() < self._deadline(pending):
            return []
        return [self._commit(pending)]

    def deadline(self) -> float | None:
        """Clock time at which `poll` commits the taps (None when there are none)."""
        return None if self._pending is None else self._deadline(self._pending)

    def current(self) -> ActiveHold | None:
        """The taps so far and the level they give."""
        pending = self._pending
        if pending is None:
            return None
        return ActiveHold(
            key=pending.key,
            elapsed_ms=(self._clock() - pending.started) * 1000.0,
            level=self._level(pending),
            repeats=pending.repeats,
        )

    def reset(self) -> None:
        """Drop the taps so far without committing them."""
        self._pending = None

    def header(self) -> dict[str, object]:
        """The session header's `"input"` object."""
        return {"mode": self.mode, **self.profile.to_header(), "tap_window_ms": self.tap_window_ms}

    def _deadline(self, pending: _Pending) -> float:
        return pending.last + self.tap_window_ms / 1000.0

    def _level(self, pending: _Pending) -> int:
        return min(self.profile.levels, pending.repeats + 1)

    def _commit(self, pending: _Pending) -> Hold:
        self._pending = None
        return Hold(
            key=pending.key,
            hold_ms=(pending.last - pending.started) * 1000.0,
            level=self._level(pending),
            exact=False,
            started=pending.started,
            repeats=pending.repeats,
        )


class DigitsInput:
    """Digits mode (`--input digits`): type the level, then the arrow.

    Digits accumulate ("1", "2" is level 12); the arrow commits the move with that level,
    clamped to 1..levels (level 1 with no digits). Backspace removes the last digit, Escape all
    of them. Nothing is timed, so `deadline` is always None. Explicit kitty repeats of an arrow
    are ignored; a legacy terminal's autorepeat moves again at level 1.
    """

    mode = "digits"
    keys = frozenset((*DIRECTIONS, *DIGITS, "backspace", "escape"))

    def __init__(self, profile: HoldProfile, *, clock: Clock = time.monotonic) -> None:
        self.profile = profile
        self._clock = clock
        self._digits = ""
        self._started: float | None = None

    def press(self, key: str, *, repeat: bool | None = None) -> list[Hold]:
        """A digit, Backspace, Escape or arrow; an arrow returns the committed move."""
        _check_key(key, self.keys)
        if repeat and key in DIRECTIONS:
            return []
        now = self._clock()
        if key in DIGITS:
            if self._started is None:
                self._started = now
            self._digits += key
            return []
        if key == "backspace":
            self._digits = self._digits[:-1]
            if not self._digits:
                self._started = None
            return []
        if key == "escape":
            self.reset()
            return []
        started = now if self._started is None else self._started
        hold = Hold(
            key=key,
            hold_ms=(now - started) * 1000.0,
            level=self._level(),
            exact=False,
            started=started,
            repeats=0,
        )
        self.reset()
        return [hold]

    def release(self, key: str) -> list[Hold]:
        """Releases carry no meaning in digits mode."""
        return []

    def poll(self) -> list[Hold]:
        """Nothing commits by time in digits mode."""
        return []

    def deadline(self) -> float | None:
        """Always None: nothing commits by time."""
        return None

    def current(self) -> ActiveHold | None:
        """The level typed so far (no key until the arrow)."""
        if self._started is None:
            return None
        return ActiveHold(
            key=None,
            elapsed_ms=(self._clock() - self._started) * 1000.0,
            level=self._level(),
            repeats=0,
        )

    def reset(self) -> None:
        """Forget the digits typed so far."""
        self._digits = ""
        self._started = None

    def header(self) -> dict[str, object]:
        """The session header's `"input"` object."""
        return {"mode": self.mode, **self.profile.to_header()}

    def _level(self) -> int:
        typed = int(self._digits) if self._digits else 1
        return min(self.profile.levels, max(1, typed))


INPUT_MODES: tuple[str, ...] = ("hold", "tap", "digits")


def make_input(mode: str, profile: HoldProfile, *, clock: Clock = time.monotonic) -> MoveInput:
    """The input for `mode` ("hold", "tap" or "digits"), sharing one profile and clock."""
    if mode == "hold":
        return HoldDetector(profile, clock=clock)
    if mode == "tap":
        return TapCounter(profile, clock=clock)
    if mode == "digits":
        return DigitsInput(profile, clock=clock)
    raise ValueError(f"unknown input mode {mode!r}: use one of {', '.join(INPUT_MODES)}")


class Calibration:
    """Measure the keyboard's autorepeat from one long hold ("hold an arrow for 2 s").

    Feed every press/autorepeat event of the hold with `feed`, then call `result`. The initial
    delay is the first repeat's time after the press; the period is the median gap between
    repeats (the median shrugs off a gap stretched by a busy event loop). A different key, or a
    silence longer than `restart_after_s` (longer than any delay we accept), starts over: the
    user is trying again.
    """

    DELAY_RANGE_MS = (150.0, 1000.0)
    PERIOD_RANGE_MS = (10.0, 200.0)
    MIN_REPEATS = 3

    def __init__(self, base: HoldProfile, *, restart_after_s: float = 1.5) -> None:
        self.base = base
        self.restart_after_s = restart_after_s
        self._key: str | None = None
        self._times: list[float] = []

    def feed(self, key: str, at: float) -> None:
        """A press or autorepeat of `key` at clock time `at` (seconds)."""
        if key != self._key or (self._times and at - self._times[-1] > self.restart_after_s):
            self._key = key
            self._times = []
        self._times.append(at)

    @property
    def repeats(self) -> int:
        """Autorepeats seen so far in the current attempt."""
        return max(0, len(self._times) - 1)

    def result(self) -> HoldProfile:
        """The base profile with the measured delay and period, marked calibrated.

        Raises:
            ValueError: fewer than `MIN_REPEATS` autorepeats were seen (message for the user).
        """
        if self.repeats < self.MIN_REPEATS:
            raise ValueError("no autorepeat seen: hold the key down for 2 seconds")
        times = self._times
        delay_ms = (times[1] - times[0]) * 1000.0
        gaps_ms = [(b - a) * 1000.0 for a, b in zip(times[1:], times[2:])]
        period_ms = statistics.median(gaps_ms)
        return replace(
            self.base,
            initial_delay_ms=_clamp(delay_ms, self.DELAY_RANGE_MS),
            repeat_period_ms=_clamp(period_ms, self.PERIOD_RANGE_MS),
            calibrated=True,
        )


def _clamp(value: float, bounds: tuple[float, float]) -> float:
    low, high = bounds
    return min(high, max(low, value))
