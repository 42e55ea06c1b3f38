"""A study's motor calibration block, for any front end: "hold until the gauge shows k, then let go".

Before the first block (practice, or the game when a study has none) a participant is asked for N
levels, one at a time, with the gauge visible. Each hold ends as a move would (the same input mode
and timing profile as play), but moves nothing: its level is the *produced* level, written at once
as a ``calibration_trial`` line (target, produced, the hold's ms, whether its release was timed
exactly) to the recorder's file. The people fit reads those lines to estimate the participant's
hand (bias and noise of the produced level, `irl_core.irl.people.hand`) instead of guessing it from play.
A front end feeds `press`, `release` and `tick` exactly as it does a `PlaySession`'s, and draws
`view()`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from irl_core.play.hold import Clock, Hold, HoldProfile
from irl_core.play.input_modes import input_mode
from irl_core.play.session import HoldView, entering_view
from irl_core.recordings.lines import CalibrationTrial
from irl_core.recordings.writer import SessionRecorder


def calibration_targets(levels: int, count: int, *, seed: int) -> list[int]:
    """`count` target levels on 2..`levels` (level 1 is a tap, no hold), each level in turn once per
    round in a shuffled order, so that ten targets on five levels ask each of 2..5 two or three times.

    Raises:
        ValueError: `count` is negative.
    """
    if count < 0:
        raise ValueError(f"calibration_block must be 0 or more, not {count}")
    pool = np.arange(2, levels + 1) if levels > 1 else np.ones(1, dtype=np.int64)
    rng = np.random.default_rng(seed)
    rounds = [rng.permutation(pool) for _ in range(-(-count // pool.size))] if count else []
    return [int(c) for c in np.concatenate(rounds)[:count]] if rounds else []


def target_words(target: int, *, times_holds: bool) -> str:
    """The instruction for one target, the same in every front end."""
    if times_holds:
        return f"Hold an arrow key until the gauge shows {target}, then let go."
    return f"Make a level {target} move with an arrow key, as in play (nothing moves here)."


# The block's words, the same in the terminal and the browser.
MOTOR_TITLE = "Calibration"
MOTOR_INTRO = ("Before you play: a few holds with no board. Each time, hold an arrow key until the gauge "
               "shows the level asked for, then let go. This measures your hand, not your play: "
               "do your best, no answer is wrong.")
# What follows the block, by the phase of the study's first block: the line shown, and the go-on key's words.
MOTOR_NEXT = {"practice": ("Calibration done. Practice comes next.", "begin practice"),
              "main": ("Calibration done. The game comes next.", "begin the game")}


def result_words(trial: CalibrationTrial) -> str:
    """What the participant is told after a trial: the level asked for and the level they made."""
    if trial.produced == trial.target:
        return f"You made {trial.produced}, as asked."
    return f"You made {trial.produced}; {trial.target} was asked."


@dataclass(frozen=True)
class MotorView:
    """What a front end draws: the target (None once done), its number among `count`, the hold
    being entered (for the gauge), the last trial, the line for the participant and, once done, what
    the go-on key does (`begin`: "begin practice", or "begin the game" when the study has no practice)."""

    target: int | None
    number: int
    count: int
    hold: HoldView | None
    last: CalibrationTrial | None
    instruction: str
    done: bool
    begin: str


class MotorBlock:
    """The calibration block's `targets`, played with `input_mode` on `profile`, each trial written
    through `recorder` (its header the study's first block's). `done` once every target has a trial;
    `write_error` says why a trial could not be written (then the block stops)."""

    def __init__(self, targets: Sequence[int], recorder: SessionRecorder, *, input_mode_name: str,
                 profile: HoldProfile, clock: Clock = time.monotonic, done_before: int = 0,
                 next_phase: str = "practice") -> None:
        if next_phase not in MOTOR_NEXT:
            raise ValueError(f"next_phase must be one of {', '.join(MOTOR_NEXT)}, not {next_phase!r}")
        self.next_phase = next_phase
        self.targets = list(targets)
        self.recorder = recorder
        self.mode = input_mode(input_mode_name)
        self.profile = profile
        self.clock = clock
        self.input = self.mode.make(profile, clock)
        self.done_before = done_before
        self.trials: list[CalibrationTrial] = []
        self.write_error: OSError | ValueError | None = None
        self.releases_seen = False
        self._last_key_at: float | None = None

    @property
    def keys(self) -> frozenset[str]:
        return self.input.keys

    @property
    def done(self) -> bool:
        return len(self.trials) >= len(self.targets) or self.write_error is not None

    def press(self, key: str, *, at: float | None = None, repeat: bool | None = None) -> list[CalibrationTrial]:
        """A key went down or autorepeated at `at` (as `PlaySession.press`); returns the trials it ended."""
        if key not in self.keys or self.done:
            return []
        at = self.clock() if at is None else at
        self._last_key_at = at
        return self._record(self.input.press(key, repeat=repeat, at=at))

    def release(self, key: str, *, at: float | None = None) -> list[CalibrationTrial]:
        """A key came up at `at`: the hold on it ends, timed exactly."""
        if key not in self.keys or self.done:
            return []
        self.releases_seen = True
        return self._record(self.input.release(key, at=at))

    def tick(self, *, until: float | None = None, keys_waiting: bool = False) -> list[CalibrationTrial]:
        """Time passed: a hold whose silence ran out ends (as `PlaySession.tick`)."""
        if keys_waiting or self.done:
            return []
        return self._record(self.input.poll(at=until))

    def entering(self) -> bool:
        return self.input.current() is not None or self.input.deadline() is not None

    def deadline(self) -> float | None:
        return self.input.deadline()

    def cancel_hold(self) -> bool:
        """Drop the hold being entered (focus lost): no trial is better than one the participant did not see."""
        if self.input.current() is None:
            return False
        self.input.cancel()
        return True

    def view(self) -> MotorView:
        target = None if self.done else self.targets[len(self.trials)]
        hold = None if self.done else entering_view(self.input, self.mode, self.profile,
                                                    releases_seen=self.releases_seen,
                                                    last_key_at=self._last_key_at, now=self.clock())
        done_line, begin = MOTOR_NEXT[self.next_phase]
        instruction = done_line if target is None else target_words(target, times_holds=self.mode.times_holds)
        return MotorView(target=target, number=self.done_before + min(len(self.trials), len(self.targets)) + 1,
                         count=self.done_before + len(self.targets), hold=hold,
                         last=self.trials[-1] if self.trials else None, instruction=instruction, done=self.done,
                         begin=begin)

    def close(self) -> None:
        """Close the file (safe to call more than once; a write failure is kept in `write_error`)."""
        self.input.reset()
        try:
            self.recorder.close()
        except (OSError, ValueError) as exc:
            self.write_error = self.write_error or exc

    def _record(self, holds: list[Hold]) -> list[CalibrationTrial]:
        made = []
        for hold in holds:
            if self.done:
                break
            trial = CalibrationTrial(target=self.targets[len(self.trials)], produced=hold.level,
                                     hold_ms=hold.hold_ms, hold_exact=hold.exact)
            try:
                self.recorder.write_trial(trial)
            except (OSError, ValueError) as exc:
                self.write_error = exc
                self.input.reset()
                break
            self.trials.append(trial)
            made.append(trial)
        if self.done:
            self.close()
        return made
