"""Measuring the keyboard's autorepeat from one long hold, for `careful play --calibrate`:
the measurement (`Calibration`) and the attempt a front end runs (`Calibrating`)."""

from __future__ import annotations

import statistics
import time
from dataclasses import replace

from irl_core.play.hold import DIRECTIONS, SHORTEST_AUTOREPEAT_DELAY_MS, Clock, HoldProfile

# The robust standard deviation of normal jitter is 1.4826 median absolute deviations.
MAD_TO_SIGMA = 1.4826


class Calibration:
    """Measure the keyboard's autorepeat from one long hold ("hold an arrow for 2 s").

    Feed every press/autorepeat event of the hold with `feed`, then call `result`. The initial
    delay is the first repeat's time after the press; the period is the median gap between
    repeats (the median shrugs off a gap stretched by a busy event loop). A different key, or a
    silence longer than `restart_after_s` (longer than any delay we accept), starts over: the
    user is trying again.

    Knowing the delay D, the first autorepeat is expected at D give or take a margin m, the
    larger of `MIN_MARGIN_MS`, 3 repeat periods (the silence that ends a hold once repeats run)
    and 6 times the spread of the repeat gaps (their robust standard deviation: how late this
    machine delivers key events). A tap then becomes a move after D + m instead of the
    uncalibrated 500 + 200 ms, and the same arrow again before D - m is a second press. D is
    one measurement; the margin's floor covers a first repeat delivered up to 100 ms late while
    calibrating, which would make D too long.
    """

    DELAY_RANGE_MS = (SHORTEST_AUTOREPEAT_DELAY_MS, 1000.0)
    PERIOD_RANGE_MS = (10.0, 200.0)
    MIN_REPEATS = 3
    MIN_MARGIN_MS = 100.0
    MARGIN_PERIODS = 3.0
    MARGIN_SPREADS = 6.0

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
        """The base profile with the measured delay, period and margin, marked calibrated.

        Raises:
            ValueError: fewer than `MIN_REPEATS` autorepeats were seen (message for the user).
        """
        if self.repeats < self.MIN_REPEATS:
            raise ValueError("no autorepeat seen: hold the key down for 2 seconds")
        times = self._times
        delay_ms = _clamp((times[1] - times[0]) * 1000.0, self.DELAY_RANGE_MS)
        gaps_ms = [(b - a) * 1000.0 for a, b in zip(times[1:], times[2:])]
        median_gap_ms = statistics.median(gaps_ms)
        period_ms = _clamp(median_gap_ms, self.PERIOD_RANGE_MS)
        spread_ms = MAD_TO_SIGMA * statistics.median(abs(gap - median_gap_ms) for gap in gaps_ms)
        margin_ms = max(self.MIN_MARGIN_MS, self.MARGIN_PERIODS * period_ms, self.MARGIN_SPREADS * spread_ms)
        return replace(
            self.base,
            initial_delay_ms=delay_ms,
            repeat_period_ms=period_ms,
            first_repeat_margin_ms=margin_ms,
            earliest_repeat_ms=max(0.0, delay_ms - margin_ms),
            calibrated=True,
        )


HOLD_S = 2.0
"""How long the player is asked to hold (the progress bar is full then)."""
SILENCE_S = 0.3
"""Silence after an autorepeat that means the key was let go."""
FIRST_REPEAT_S = Calibration.DELAY_RANGE_MS[1] / 1000 + 0.2
"""Silence after the press, before any autorepeat, that means the key was let go (longer than
any initial delay the calibration accepts)."""


class Calibrating:
    """One calibration as a front end runs it: "hold an arrow for 2 seconds", then a result.

    Feed every arrow press and autorepeat with `press` (timed by when it came, `at`), a release
    with `release`, and call `tick` while `measuring`: the attempt ends at the key's release (a
    release event, or a silence of `SILENCE_S` once the autorepeat has started, `FIRST_REPEAT_S`
    before). Then `result` holds the calibrated profile, or `problem` says why there is none;
    `restart` tries again from the same base profile. `calibration` is the measurement so far.
    """

    def __init__(self, base: HoldProfile, *, clock: Clock = time.monotonic) -> None:
        self.base = base
        self.clock = clock
        self._restart()

    def _restart(self) -> None:
        self.calibration = Calibration(self.base)
        self._first: float | None = None
        self._last: float | None = None
        self.result: HoldProfile | None = None
        self.problem: str | None = None

    def restart(self) -> None:
        """Forget this attempt (and its result): the player tries again."""
        self._restart()

    @property
    def repeats(self) -> int:
        """Autorepeats seen so far in the current attempt."""
        return self.calibration.repeats

    @property
    def held_s(self) -> float:
        """Seconds since the attempt's first key (0 before it)."""
        return 0.0 if self._first is None else self.clock() - self._first

    @property
    def measuring(self) -> bool:
        """A key came and the attempt has not ended."""
        return self._last is not None and self.result is None and self.problem is None

    def press(self, key: str, *, at: float | None = None) -> None:
        """An arrow press or autorepeat at `at` (default: now); other keys, and keys after the
        attempt ended, are ignored."""
        if key in DIRECTIONS and self.result is None and self.problem is None:
            came = self.clock() if at is None else at
            if self._first is None:
                self._first = came
            self._last = came
            self.calibration.feed(key, came)

    def release(self, key: str) -> None:
        """An arrow came up: the attempt ends."""
        if key in DIRECTIONS and self._first is not None and self.result is None:
            self._finish()

    def tick(self, *, until: float | None = None, keys_waiting: bool = False) -> None:
        """End the attempt once the key has been silent long enough by `until` (default: now),
        unless key events that came are still queued (`keys_waiting`)."""
        if not self.measuring:
            return
        assert self._last is not None
        silence = SILENCE_S if self.calibration.repeats else FIRST_REPEAT_S
        until = self.clock() if until is None else until
        if until - self._last >= silence and not keys_waiting:
            self._finish()

    def _finish(self) -> None:
        try:
            self.result = self.calibration.result()
        except ValueError as exc:
            self.problem = str(exc)


def _clamp(value: float, bounds: tuple[float, float]) -> float:
    low, high = bounds
    return min(high, max(low, value))
