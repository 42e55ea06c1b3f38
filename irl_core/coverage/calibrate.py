"""Learning the scales of calibrated intervals (`irl_core.irl.intervals.calibrated`) from `careful check`'s refits.

For one symbol, each dataset's refit needs the smallest scale w >= 1 by which its half-widths around its
point must grow for its interval to hold the truth the dataset was simulated with (`needed_scales`: for a
truth t below the interval [l, h] around the point p, w = (p - t) / (p - l); above it, (t - p) / (h - p);
per cell, the largest over the symbol's cells; infinite where the side the truth lies on has no width).
A player's scale is the smallest w that makes the share of its datasets held reach the confidence level:
the ceil(confidence * n)-th smallest of its datasets' needs. The symbol's scale is the largest over the
players checked (the fit's own model and every rival), and at least 1: the intervals are never narrowed.
"""

from __future__ import annotations

import math

import numpy as np

from irl_core.irl.intervals.calibrated import Calibration, options_text, world_digest
from irl_core.irl.result import FitResult


def needed_scales(points: np.ndarray, intervals: np.ndarray, truth: np.ndarray, columns: list[int], *,
                  tolerance: float) -> np.ndarray:
    """(n,) per dataset (its refit's `points` (n, k) and `intervals` (n, k, 2)), the smallest w >= 1 whose
    widening of the unknowns `columns` holds `truth` (k,) in every one of them (an end within `tolerance` of the
    truth holds it, as the tally counts); inf where none does."""
    out = np.ones(len(points))
    for i in range(len(points)):
        for j in columns:
            point, (low, high), t = points[i, j], intervals[i, j], truth[j]
            if t < low - tolerance:
                need = (point - t - tolerance) / (point - low) if point > low else math.inf
            elif t > high + tolerance:
                need = (t - point - tolerance) / (high - point) if high > point else math.inf
            else:
                need = 1.0
            out[i] = max(out[i], need)
    return out


def level_scale(needs: np.ndarray, confidence: float) -> float:
    """The smallest w with at least `confidence` of `needs` (n,) at or below it (1 at least; inf where the
    datasets that must be held include one no w holds; 1 for no datasets)."""
    if not needs.size:
        return 1.0
    held = math.ceil(confidence * needs.size - 1e-9)
    return max(1.0, float(np.sort(needs)[held - 1]))


def learn_scales(sources: list[tuple[np.ndarray, np.ndarray, np.ndarray]], symbols: tuple[str, ...], *,
                 confidence: float, tolerance: float) -> dict[str, float | None]:
    """Per symbol (in the order of the unknowns), the scale that brings every source's coverage to `confidence`:
    `sources` holds, per player checked, its datasets' refits (points (n, k), intervals (n, k, 2), those with
    intervals only) and the truth (k,) they were simulated with. None where no scale does. A source whose truth
    for the symbol is not finite (no unit to compare in) says nothing of it."""
    out: dict[str, float | None] = {}
    for symbol in dict.fromkeys(symbols):
        columns = [j for j, s in enumerate(symbols) if s == symbol]
        scale = 1.0
        for points, intervals, truth in sources:
            if np.isfinite(truth[columns]).all():
                needs = needed_scales(points, intervals, truth, columns, tolerance=tolerance)
                scale = max(scale, level_scale(needs, confidence))
        out[symbol] = None if math.isinf(scale) else scale
    return out


def calibration_of(result: FitResult, scales: dict[str, float | None], *, players: tuple[str, ...], datasets: int,
                   seed: int) -> Calibration:
    """The calibration `careful check` writes: `scales` learned for `result`'s fit options and world, with the
    design they were learned on (`players` checked, own model first; `datasets` of each; the check's `seed`)."""
    world = result.recorded_world or result.world
    return Calibration(scales=tuple(scales.items()), confidence=result.options.confidence,
                       options=options_text(result.options), world=world.name, world_digest=world_digest(world),
                       players=players, datasets=datasets, episodes=result.demos.episodes, seed=seed)
