"""Measuring the keyboard's autorepeat from one long hold, for `careful play --calibrate`."""

from __future__ import annotations

import statistics
from dataclasses import replace

from careful_tui.keys.hold import HoldProfile


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
