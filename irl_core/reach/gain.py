"""The expected gain of a reach, and the grid of choices a player and a fit reason over (docs/reach.md).

A reach aimed at ``aim`` taking ``d`` ms ends at aim + N(0, sd^2 I) with sd = a + b * distance / (d / 1000).
The chance that it ends in a circle of radius R whose centre is delta from the aim is the chance that a
non-central chi-square of 2 degrees of freedom and non-centrality (delta / sd)^2 is at most (R / sd)^2
(Trommershäuser, Maloney & Landy 2003 compute the same by integrating the normal over the circle).
The expected gain of the choice is

    EG(aim, d) = sum over symbols s of points_s * H_s(aim, d) - cost_per_second * d / 1000,

H_s the expected number of circles of symbol s holding the endpoint (circles add where they overlap).
EG is linear in the points: a grid of choices keeps H once (`ChoiceGrid.hits`) and any points give
EG by one product, which is what lets the fit try many points cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import chndtr

from irl_core.worlds.reach import ReachWorld, Spread

# The choice grid's defaults: aims this fraction of the smallest radius apart, durations log-spaced.
AIM_STEPS_PER_RADIUS = 16
DURATIONS = 24


def hit_chances(world: ReachWorld, aims: ArrayLike, durations_ms: ArrayLike, *,
                spread: Spread | None = None) -> np.ndarray:
    """H[s, ...]: the expected number of circles of symbol s (`world.symbols` order) holding the endpoint of
    reaches aimed at aims (..., 2) in durations (...) (broadcast together), by the spread law (the world's,
    or `spread`)."""
    aims = np.asarray(aims, dtype=float)
    durations = np.asarray(durations_ms, dtype=float)
    sd = world.sd(aims, durations, spread)
    shape = np.broadcast_shapes(aims.shape[:-1], durations.shape)
    hits = np.zeros((len(world.symbols), *shape))
    for region in world.regions:
        offset = np.hypot(*np.moveaxis(aims - np.asarray(region.centre), -1, 0))
        hits[world.symbols.index(region.symbol)] += chndtr((region.radius / sd) ** 2, 2, (offset / sd) ** 2)
    return hits


def expected_gain(world: ReachWorld, aims: ArrayLike, durations_ms: ArrayLike, *,
                  points: ArrayLike | None = None, spread: Spread | None = None) -> np.ndarray:
    """EG(...) of reaches aimed at aims (..., 2) in durations (...), with the world's points or `points` (S,)
    in `world.symbols` order, and the world's spread law or `spread`."""
    weights = np.asarray(list(world.points.values()) if points is None else points, dtype=float)
    hits = hit_chances(world, aims, durations_ms, spread=spread)
    return np.tensordot(weights, hits, axes=1) - world.cost(durations_ms)


@dataclass(frozen=True)
class ChoiceGrid:
    """The choices a player picks from: K aims on a square lattice around the circles by D durations.

    aims[k] = (x, y); durations[j] in ms, log-spaced from min_ms to max_ms; hits[s, k, j] as `hit_chances`;
    cost[j] the time cost; step the lattice's spacing.
    """

    aims: np.ndarray
    durations: np.ndarray
    hits: np.ndarray
    cost: np.ndarray
    step: float

    def gain(self, points: ArrayLike) -> np.ndarray:
        """EG[k, j] of every choice for points (S,)."""
        return np.tensordot(np.asarray(points, dtype=float), self.hits, axes=1) - self.cost[None, :]

    def nearest_duration(self, durations_ms: ArrayLike) -> np.ndarray:
        """(...) the index of the grid duration nearest each duration (...) on a log scale."""
        logs = np.log(self.durations)
        edges = (logs[1:] + logs[:-1]) / 2
        return np.searchsorted(edges, np.log(np.asarray(durations_ms, dtype=float)))


def choice_grid(world: ReachWorld, *, spread: Spread | None = None, step: float | None = None,
                durations: int = DURATIONS) -> ChoiceGrid:
    """The grid of choices over the circles' bounding box widened by the largest radius, inside the field.

    `step` defaults to the smallest radius / AIM_STEPS_PER_RADIUS."""
    radii = np.array([region.radius for region in world.regions])
    centres = np.array([region.centre for region in world.regions])
    step = float(step or radii.min() / AIM_STEPS_PER_RADIUS)
    low = np.maximum((centres - radii[:, None]).min(axis=0) - radii.max(), 0.0)
    high = np.minimum((centres + radii[:, None]).max(axis=0) + radii.max(), np.asarray(world.field))
    xs = np.arange(low[0], high[0] + step / 2, step)
    ys = np.arange(low[1], high[1] + step / 2, step)
    aims = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    times = np.geomspace(world.min_ms, world.max_ms, durations)
    hits = hit_chances(world, aims[:, None, :], times[None, :], spread=spread)
    return ChoiceGrid(aims=aims, durations=times, hits=hits, cost=world.cost(times), step=step)


def best_choice(grid: ChoiceGrid, points: ArrayLike) -> tuple[np.ndarray, float]:
    """The expected-gain maximiser on the grid: its aim (2,) and duration in ms (the first of ties)."""
    k, j = np.unravel_index(int(np.argmax(grid.gain(points))), grid.hits.shape[1:])
    return grid.aims[k], float(grid.durations[j])


def soft_choice_log_probabilities(grid: ChoiceGrid, points: ArrayLike, beta: float) -> np.ndarray:
    """log pi[k, j] = beta * EG[k, j] - log sum exp(beta * EG): the soft-optimal player's choice, in log space."""
    scaled = beta * grid.gain(points)
    top = scaled.max()
    return scaled - (top + np.log(np.exp(scaled - top).sum()))
