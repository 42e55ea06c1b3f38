"""Computer reachers: the expected-gain maximiser, the soft-optimal player and the person-like ``hand``,
and the endpoint a simulated reach lands on (docs/reach.md).

All choose from a `ChoiceGrid`. The maximiser takes the grid's best (aim, duration) every trial. The
soft-optimal player picks a choice with probability proportional to exp(beta * EG) and then misplaces
its aim by a normal error of sd `aim_sd` per axis (its own aim noise, before the world's scatter); the
aim recorded is the misplaced one, and the endpoint scatters around it by the world's spread law.

The person-like ``hand`` (`REACH_KINDS`) is none of the fit's models: it means the maximiser's choice,
misplaces the aim by its own noise (sd `aim_sd` field units per axis), times the reach by hand (the meant
duration times exp(N(0, `weber`)), Weber's law as the grid's ``timing`` player), and lapses with
probability `lapse`: half of its lapses are aimed at random (anywhere in the grid's box), half rushed
(the shortest duration allowed times exp(|N(0, `weber`)|)). A duration outside the world's limits is
refused and the reach repeated, as in play.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from irl_core.players.experts import SIMULATED_AT, app_version, expert_name
from irl_core.players.person_like import REACH_KINDS
from irl_core.reach.gain import ChoiceGrid, best_choice, choice_grid, soft_choice_log_probabilities
from irl_core.recordings.reach_lines import ReachHeader, ReachStep
from irl_core.recordings.writer import RecordingWriter
from irl_core.support.safe_files import built_beside
from irl_core.worlds.reach import ReachWorld


class Reacher(Protocol):
    """A computer player of a reach world: its `player` name and one (aim (2,), duration in ms) a trial."""

    player: str

    def choose(self, rng: np.random.Generator) -> tuple[np.ndarray, float]: ...


@dataclass
class OptimalReacher:
    """The expected-gain maximiser by grid search: the same best choice every trial."""

    grid: ChoiceGrid
    points: np.ndarray
    player: str = expert_name("optimal")
    _best: tuple[np.ndarray, float] | None = field(default=None, init=False, repr=False)

    def choose(self, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        if self._best is None:
            self._best = best_choice(self.grid, self.points)
        return self._best[0].copy(), self._best[1]


@dataclass
class SoftReacher:
    """The soft-optimal player: a grid choice with probability exp(beta * EG) / Z, its aim then misplaced by
    N(0, aim_sd^2) per axis and kept inside `extent`, the field (width, height)."""

    grid: ChoiceGrid
    points: np.ndarray
    beta: float
    aim_sd: float
    extent: tuple[float, float]
    player: str = ""
    _probabilities: np.ndarray | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        self.player = self.player or expert_name("boltzmann", self.beta)

    def choose(self, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        if self._probabilities is None:
            self._probabilities = np.exp(soft_choice_log_probabilities(self.grid, self.points, self.beta)).ravel()
        k, j = np.unravel_index(rng.choice(self._probabilities.size, p=self._probabilities), self.grid.hits.shape[1:])
        aim = np.clip(self.grid.aims[k] + rng.normal(0.0, self.aim_sd, 2), 0.0, self.extent)
        return aim, float(self.grid.durations[j])


# A hand asked to time a reach this many times without landing inside the limits takes the nearest limit.
_MAX_REDRAWS = 100


@dataclass
class HandReacher:
    """The person-like ``hand`` (module docstring): the maximiser's choice (aim, duration) meant, done by hand."""

    grid: ChoiceGrid
    points: np.ndarray
    limits: tuple[float, float]
    extent: tuple[float, float]
    lapse: float
    aim_sd: float
    weber: float
    player: str = field(default="", init=False)
    _best: tuple[np.ndarray, float] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        # named as the grid's person-like players are: person:KIND(parameters)
        self.player = f"person:hand(lapse={self.lapse:g}, aim_sd={self.aim_sd:g}, weber={self.weber:g})"

    def choose(self, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        if self._best is None:
            self._best = best_choice(self.grid, self.points)
        aim, duration = self._best[0].copy(), self._best[1]
        lapsed = rng.random() < self.lapse
        rushed = lapsed and rng.random() < 0.5
        if lapsed and not rushed:
            aim = rng.uniform(self.grid.aims.min(axis=0), self.grid.aims.max(axis=0))
        aim = np.clip(aim + rng.normal(0.0, self.aim_sd, 2), 0.0, self.extent)
        low, high = self.limits
        for _ in range(_MAX_REDRAWS):
            timed = low * np.exp(abs(rng.normal(0.0, self.weber))) if rushed else duration * np.exp(rng.normal(0.0, self.weber))
            if low <= timed <= high:
                return aim, float(timed)
        return aim, float(np.clip(timed, low, high))


def reacher(world: ReachWorld, policy: str, *, beta: float = 1.0, **parameters: float) -> Reacher:
    """The reacher `policy` names ("optimal", "boltzmann" or a kind of `REACH_KINDS`, with `parameters` in
    place of its defaults) for the world's own points, on the world's default grid; the soft-optimal
    player's aim noise is one grid step.

    Raises `ValueError` for another policy, a parameter the kind does not have or one out of its range."""
    grid = choice_grid(world)
    points = np.array(list(world.points.values()))
    if policy == "optimal":
        return OptimalReacher(grid, points)
    if policy == "boltzmann":
        return SoftReacher(grid, points, beta=beta, aim_sd=grid.step, extent=world.field)
    if policy not in REACH_KINDS:
        raise ValueError(f"a reach world has the optimal, boltzmann and {', '.join(REACH_KINDS)} players, not {policy!r}")
    if unknown := sorted(set(parameters) - set(REACH_KINDS[policy])):
        raise ValueError(f"the {policy} player has no parameter {', '.join(unknown)}; its parameters are "
                         f"{', '.join(REACH_KINDS[policy])}")
    values = {name: float(parameters.get(name, default)) for name, default in REACH_KINDS[policy].items()}
    if not 0 <= values["lapse"] <= 1 or values["aim_sd"] < 0 or values["weber"] < 0:
        raise ValueError("lapse is a probability (0 to 1); aim_sd and weber are 0 or more")
    return HandReacher(grid, points, limits=(world.min_ms, world.max_ms), extent=world.field, **values)


def simulate_reaches(world: ReachWorld, player: Reacher, *, trials: int, seed: int) -> list[ReachStep]:
    """`trials` reaches by `player`, one episode each, as the step lines a recording holds (the same seed,
    the same lines)."""
    rng = np.random.default_rng(seed)
    steps, score = [], 0.0
    for episode in range(trials):
        aim, duration = player.choose(rng)
        end = world.endpoint(aim, duration, rng)
        endpoint = (float(end[0]), float(end[1]))
        reward = world.score_of(endpoint, duration)
        score += reward
        steps.append(ReachStep(episode=episode, t=0, aim=(float(aim[0]), float(aim[1])), duration_ms=duration,
                               endpoint=endpoint, regions=tuple(world.regions_holding(endpoint)), reward=reward,
                               score=score, hold_exact=True))
    return steps


def simulate_reaches_to_file(path: str | Path, world: ReachWorld, player: Reacher, *, trials: int,
                             seed: int) -> Counter[str]:
    """Write `trials` simulated reaches as a new recording at `path`, built beside it and renamed into place
    when whole. Returns how often each circle's symbol was hit ("none": no circle).

    Raises:
        OSError: the file cannot be written (nothing is left), or `path` exists (`FileExistsError`).
    """
    steps = simulate_reaches(world, player, trials=trials, seed=seed)
    header = ReachHeader(world=world, player=player.player, created=SIMULATED_AT, seed=seed, app_version=app_version())
    with built_beside(path) as temporary, RecordingWriter(temporary, header, sync_episodes=False) as writer:
        writer.write_many(steps)
    return Counter(symbol for step in steps for symbol in (step.regions or ("none",)))
