"""The calibration block of a reach world with ``noise = "own"`` (docs/reach.md): reaches to a lone target at
four deadlines, and the spread law fitted from where they ended.

With a participant's own pointer the endpoint's scatter is theirs, not the world's ``spread``: the fit of the
points needs their law, and the decision trials alone mix it up with where they chose to aim. Dean, Wu &
Maloney (2007) measure it first: reaches to a target with nothing else on the field, each to be made in a
given time. Here the target is the world's circle of most points, alone, at its place (so the law is measured
at the distance it is used at), and the deadlines are four durations spread evenly on a log scale inside
``[min_ms, max_ms]``, at 1/8, 3/8, 5/8 and 7/8 of the way: the law's x = distance / seconds then takes four
values wide apart, which is what tells a (the scatter at any speed) from b (the scatter that grows with
speed), and each deadline keeps an eighth of the log range from the limits, so a reach a little off its
deadline is still inside them (a reach outside them is refused and repeated, as in the game).

The participant aims at the target's centre; a trial's miss is endpoint - centre, and the law is fitted from
the trials' misses and durations by `irl_core.reach.fit.fit_spread` (maximum likelihood, Laplace intervals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from irl_core.reach.fit import Note, SpreadFit, fit_spread
from irl_core.recordings.reach_reader import Reaches
from irl_core.worlds.reach import ReachWorld, Region

# Where the four deadlines sit on the log scale from min_ms (0) to max_ms (1).
DEADLINE_PLACES = (1 / 8, 3 / 8, 5 / 8, 7 / 8)
# Reaches a deadline asks for, unless the study says otherwise.
TRIALS_PER_DEADLINE = 10


def calibration_deadlines(world: ReachWorld) -> tuple[float, ...]:
    """The four deadlines (ms) of the world's calibration block, shortest first, rounded to whole ms (as the page
    words them) but never past the limits."""
    low, high = np.log(world.min_ms), np.log(world.max_ms)
    return tuple(float(np.clip(round(np.exp(low + place * (high - low))), world.min_ms, world.max_ms))
                 for place in DEADLINE_PLACES)


def calibration_world(world: ReachWorld) -> ReachWorld:
    """The world of the calibration block: the world's circle of most points alone, worth nothing (a
    calibration reach scores nothing), and the world's start, limits and time cost otherwise."""
    target = max(world.regions, key=lambda region: region.points)
    lone = Region(symbol=target.symbol, centre=target.centre, radius=target.radius, points=0.0)
    return world.model_copy(update={"regions": (lone,), "name": f"{world.name} calibration"})


def calibration_schedule(world: ReachWorld, per_deadline: int = TRIALS_PER_DEADLINE) -> list[float]:
    """The deadline of each trial of the block in order: `per_deadline` reaches at each deadline, the longest
    deadline first (the easiest, to learn the task on), as Dean et al. block them."""
    return [deadline for deadline in reversed(calibration_deadlines(world)) for _ in range(per_deadline)]


@dataclass(frozen=True)
class CalibrationFit:
    """The spread law fitted from a calibration block, and the notes of its fit."""

    spread: SpreadFit
    trials: int
    notes: tuple[Note, ...]

    def to_json(self) -> dict[str, object]:
        """The law as a participant's recording stores it: a, b, their intervals and how many reaches."""
        law, interval = self.spread.spread, self.spread.interval
        return {"a": law.a, "b": law.b, "trials": self.trials,
                "interval": None if interval is None else {name: list(bounds) for name, bounds in interval.items()},
                "notes": [note.code for note in self.notes]}


def fit_calibration(world: ReachWorld, durations_ms: ArrayLike, endpoints: ArrayLike, *,
                    confidence: float = 0.95) -> CalibrationFit:
    """The spread law from calibration reaches of `world` (its own world, not `calibration_world`): durations
    (n,) in ms and endpoints (n, 2), each aimed at the lone target's centre."""
    lone = calibration_world(world)
    durations = np.asarray(durations_ms, dtype=float)
    endpoints = np.asarray(endpoints, dtype=float).reshape(-1, 2)
    aims = np.broadcast_to(np.asarray(lone.regions[0].centre, dtype=float), endpoints.shape)
    notes: list[Note] = []
    law = fit_spread(Reaches(lone, aims, durations, endpoints, files=1), known=False, confidence=confidence,
                     notes=notes)
    return CalibrationFit(law, len(durations), tuple(notes))
