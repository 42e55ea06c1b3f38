"""The invariants every fit's intervals keep, whatever made them (docs/answers.md, "Honest answers").

For every fitted reward: the point lies inside its interval; a reward the data bound on one side only
has an interval open to -rmax or +rmax on that side, and is read as that bound ("at most X"), never as
its point; the notes say what the table says. They are enforced here, once, after every kind of
interval (identified, bootstrap, the timing fit's own), so that no path can print a number outside its
own interval.

Why a point can fall outside a bootstrap interval: the percentile interval is the spread of refits, and
where the likelihood is flat in a reward (bounded on one side only) the refits land anywhere along the
flat side, or the full fit's search stopped at a place the refits do not return to. The first is the
one-sided case (opened here to the bound); the second a biased refit distribution, which the interval is
widened to cover (the point is then an end of the interval, and a note says so). A point at ±rmax whose
refits all stayed there has an interval of no width that says nothing: it becomes the whole range (the
``at_bound`` note names it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from irl_core.irl.identification import MOVE
from irl_core.irl.notes import Note
from irl_core.irl.people import FLAT_DROP
from irl_core.irl.result import FitResult, at_bound

# Ends this close (relative to rmax) count as the same number: the solvers' tolerance, not a real gap.
TOLERANCE = 1e-9
# An interval narrower than this (relative to rmax) has no width: its refits never moved (note
# ``refits_never_moved``), whatever the solvers' last digits did.
ZERO_WIDTH = 1e-6


@dataclass(frozen=True)
class Honest:
    """Intervals after the invariants: bounds (k, 2), and the unknowns each rule moved (index arrays)."""

    bounds: np.ndarray
    opened: np.ndarray
    widened: np.ndarray


def honest_intervals(theta: np.ndarray, bounds: np.ndarray, *, flat: np.ndarray | None, rmax: float) -> Honest:
    """`bounds` (k, 2) made to hold `theta` (k,), with each one-sided reward (`flat` (k,): -1 bounded above
    only, +1 below only, 0 both) open to the bound on its free side."""
    theta = np.asarray(theta, dtype=float)
    out = np.array(bounds, dtype=float, copy=True)
    sides = np.zeros(len(theta)) if flat is None else np.asarray(flat)
    slack = TOLERANCE * max(rmax, 1.0)
    one_side = ((sides < 0) & (out[:, 0] > -rmax)) | ((sides > 0) & (out[:, 1] < rmax))
    out[sides < 0, 0] = -rmax
    out[sides > 0, 1] = rmax
    # A point at ±rmax whose interval has no width (its refits never left the bound, or it is open towards the
    # bound it sits on): the bound set it, and the interval says nothing. `ZERO_WIDTH`, as the rules judge width.
    stuck = at_bound(theta, rmax) & (out[:, 1] - out[:, 0] <= ZERO_WIDTH * max(rmax, 1.0))
    opened = np.flatnonzero(one_side | stuck)
    out[stuck] = [-rmax, rmax]
    widened = np.flatnonzero((theta < out[:, 0] - slack) | (theta > out[:, 1] + slack))
    out[:, 0] = np.minimum(out[:, 0], theta)
    out[:, 1] = np.maximum(out[:, 1], theta)
    return Honest(bounds=out, opened=opened, widened=widened)


def one_sided(bounds: np.ndarray, rmax: float) -> np.ndarray:
    """(k,) -1 where an interval is open below only (read "at most" its upper end), +1 where open above only
    ("at least" its lower end), 0 where it is closed on both sides or open on both."""
    low_open = at_bound(bounds[:, 0], rmax) & (bounds[:, 0] < 0)
    high_open = at_bound(bounds[:, 1], rmax) & (bounds[:, 1] > 0)
    return np.where(low_open & ~high_open, -1, np.where(high_open & ~low_open, 1, 0))


def honest_notes(labels: tuple[str, ...], theta: np.ndarray, honest: Honest | None, *, flat: np.ndarray | None,
                 rmax: float) -> list[Note]:
    """The notes the invariants owe the reader: the one-sided rewards said as their bound (the interval's end
    where there is one, else the point's side only), and the points an interval was widened to hold."""
    notes = []
    sides = np.zeros(len(labels)) if flat is None else np.asarray(flat)
    if sides.any():
        if honest is not None:
            ends = np.where(sides < 0, honest.bounds[:, 1], honest.bounds[:, 0])
            said = [f"{label} {'at most' if side < 0 else 'at least'} {end:.3g}"
                    for label, end, side in zip(labels, ends, sides) if side]
        else:
            said = [f"{label} {'below' if side < 0 else 'above'} (no interval was asked for: the point "
                    f"{value:.3g} is where the search stopped, not an estimate)"
                    for label, value, side in zip(labels, theta, sides) if side]
        notes.append(Note("one_sided", "bounded on one side only (moving them to the bound, {rmax}, costs the "
                                       f"likelihood less than {FLAT_DROP:g}): " + "; ".join(said)))
    if honest is not None and honest.widened.size:
        names = ", ".join(labels[j] for j in honest.widened)
        notes.append(Note("interval_widened", f"the intervals of {names} were widened to hold the point estimate: "
                                              "the refits of resampled episodes sat to one side of it (a biased "
                                              "estimate), so the point is an end of its interval"))
    return notes


def bounded_cells(result: FitResult) -> dict[tuple[int, int], tuple[int, float]]:
    """(row, col) -> (side, bound) for every cell whose reward the data bound on one side only: side -1 reads "at
    most bound", +1 "at least bound". Such a cell's point is no estimate, so the grids show the bound instead.
    Empty without intervals; a move's cost is no cell's."""
    if result.intervals is None:
        return {}
    intervals = np.asarray(result.intervals, dtype=float)
    sides = one_sided(intervals, float(result.rmax))
    basis = result.unknowns.basis.tocsc()
    out: dict[tuple[int, int], tuple[int, float]] = {}
    for j in np.flatnonzero(sides):
        if result.unknowns.symbols[j] == MOVE:
            continue
        bound = float(intervals[j, 1] if sides[j] < 0 else intervals[j, 0])
        for state in basis[:, j].indices:
            if state < len(result.mdp.cells):
                row, col = result.mdp.cells[state]
                out[(int(row), int(col))] = (int(sides[j]), bound)
    return out


def invariant_violations(result: FitResult) -> list[str]:
    """What in `result` breaks the rules every answer keeps (docs/answers.md, "Honest answers"), one sentence
    each; empty for an honest fit. The property tests and `bench/bench_invariants.py` ask it of every fit.

    The rules: every point inside its interval; intervals ordered and within ±rmax; zero width only where the
    lp's identified set pins the value or a note (`refits_never_moved`) says the refits never moved; the
    one-sided note's bounds are the table's interval ends."""
    if result.intervals is None:
        return []
    codes = {note.code for note in result.notes}
    rmax = float(result.rmax) / ((result.recorded_world or result.world).cost_per_second
                                 if result.reward_unit == "seconds of holding" else 1.0)
    slack = ZERO_WIDTH * max(rmax, 1.0)
    out = []
    for label, point, (low, high) in zip(result.labels, result.theta, result.intervals):
        if not low - slack <= point <= high + slack:
            out.append(f"{label}: the point {point:.6g} lies outside its interval [{low:.6g}, {high:.6g}]")
        if not (-rmax - slack <= low <= high + slack and high <= rmax + slack):
            out.append(f"{label}: the interval [{low:.6g}, {high:.6g}] is not ordered within ±rmax {rmax:g}")
        if high - low <= slack and result.interval_kind != "identified" and "refits_never_moved" not in codes:
            out.append(f"{label}: a zero-width interval [{low:.6g}, {high:.6g}] that no note explains")
    ends = {label: (low, high) for label, (low, high) in zip(result.labels, result.intervals)}
    for note in result.notes:
        if note.code != "one_sided":
            continue
        for label, side, value in re.findall(r"([^:;]+?) at (most|least) (-?\d[\d.]*(?:e[+-]?\d+)?)", note.sentence):
            label = label.strip()
            if label not in ends:
                continue
            end = ends[label][1] if side == "most" else ends[label][0]
            if abs(float(f"{end:.3g}") - float(value)) > 1e-9 * max(1.0, abs(end)):
                out.append(f"{label}: the note says at {side} {value}, the table's interval ends at {end:.6g}")
    return out
