"""The other two ways to enter a move: tap an arrow k times (`TapCounter`), or type the level and
then the arrow (`DigitsInput`). `irl_core.play.input_modes` names every mode and builds its input.

Like `irl_core.play.hold`, nothing here imports Textual; every class takes a `clock`.
"""

from __future__ import annotations

import time

from irl_core.play.hold import (
    DIGITS,
    DIRECTIONS,
    ActiveHold,
    Clock,
    Hold,
    HoldProfile,
    PendingHold,
    SilenceEnded,
    check_key,
)


class TapCounter(SilenceEnded):
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
        self._pending: PendingHold | None = None

    def press(self, key: str, *, repeat: bool | None = None, at: float | None = None) -> list[Hold]:
        """A tap of `key` at time `at` (default: now); returns the move it committed (a pause
        of the tap window before it, or a different arrow, commits at once)."""
        check_key(key, self.keys)
        if repeat:
            return []
        now = self._now(at)
        done = self.poll(at=now)
        pending = self._pending
        if pending is not None and pending.key == key:
            pending.repeats += 1
            pending.last = now
            return done
        if pending is not None:
            done.append(self._end(pending))
        self._pending = PendingHold(key=key, started=now, last=now)
        return done

    def release(self, key: str, *, at: float | None = None) -> list[Hold]:
        """Releases carry no meaning in tap mode."""
        return []

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

    def cancel(self) -> None:
        """As `reset`: a key held down in tap mode already taps on every autorepeat."""
        self.reset()

    def header(self) -> dict[str, object]:
        """The session header's `"input"` object."""
        return {"mode": self.mode, **self.profile.to_header(), "tap_window_ms": self.tap_window_ms}

    def _deadline(self, pending: PendingHold) -> float:
        return pending.last + self.tap_window_ms / 1000.0

    def _level(self, pending: PendingHold) -> int:
        return min(self.profile.levels, pending.repeats + 1)

    def _end(self, pending: PendingHold) -> Hold:
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

    def press(self, key: str, *, repeat: bool | None = None, at: float | None = None) -> list[Hold]:
        """A digit, Backspace, Escape or arrow at time `at` (default: now); an arrow returns the committed move."""
        check_key(key, self.keys)
        if repeat and key in DIRECTIONS:
            return []
        now = self._clock() if at is None else at
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

    def release(self, key: str, *, at: float | None = None) -> list[Hold]:
        """Releases carry no meaning in digits mode."""
        return []

    def poll(self, *, at: float | None = None) -> list[Hold]:
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

    def cancel(self) -> None:
        """As `reset`: digits mode times nothing, so there is no held key to wait out."""
        self.reset()

    def header(self) -> dict[str, object]:
        """The session header's `"input"` object."""
        return {"mode": self.mode, **self.profile.to_header()}

    def _level(self) -> int:
        typed = int(self._digits) if self._digits else 1
        return min(self.profile.levels, max(1, typed))
