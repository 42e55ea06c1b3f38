"""Rewards of a model of people that no recorded action can lead into, found before the fit.

Such a reward (`unreached`: every recorded (s, a) has P(cell | s, a) = 0) is not bounded below by the data.
Lowering it only makes unrecorded actions, those that risk the cell, less likely, so the likelihood rises
toward a limit as it falls and its maximum within the box is at -rmax: the fit holds it there
(`fit.fit_player`, which frees it again if the gradient there says otherwise) instead of walking
L-BFGS-B down a flat direction until its iteration limit (issue 32: a 24x24 world's fit "not converged in
124.9 s", its cliff cells left wherever the walk stopped, an agent falling 11%). `people_checks` then
says how high each held reward can be before the data object: its interval is [-rmax, that bound].
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from irl_core.irl.choices import Player, PlayerModel
from irl_core.irl.notes import Note
from irl_core.irl.people.likelihood import log_likelihood
from irl_core.irl.qmap import Unknowns
from irl_core.worlds.mdp import MDP

# A reward moved to its bound whose log likelihood falls by less than this (chi-square(1) at 95%, halved)
# is not bounded on that side by the data.
FLAT_DROP = 1.92
# Beyond this many unknowns on one side, only the joint move is tried (one soft Bellman fixed point each).
MAX_ONE_BY_ONE = 40


def unreached(mdp: MDP, unknowns: Unknowns, counts: np.ndarray) -> np.ndarray:
    """(k,) True for the unknowns none of whose cells any recorded action (counts N (S, A) > 0) can lead into."""
    entries = (np.asarray(counts, dtype=float).ravel() > 0).astype(float) @ mdp.P  # (S,) reachable in one step
    basis = sp.csc_matrix(unknowns.basis)
    return np.asarray(abs(basis).T @ (entries > 0)).ravel() == 0


# Bisection steps for a held reward's upper bound: its resolution is 2 rmax / 2^steps (0.5 at rmax 1000).
BOUND_STEPS = 12


def bound_groups(held: np.ndarray) -> list[list[int]]:
    """The unknowns the held bounds (`people_checks`) bound together: each held one alone, or all in one group beyond
    `MAX_ONE_BY_ONE`."""
    indices = [int(j) for j in np.flatnonzero(held)]
    return [[j] for j in indices] if len(indices) <= MAX_ONE_BY_ONE else [indices]


def bounds_of(k: int, groups: list[list[int]], bounds: list[float]) -> np.ndarray:
    """(k,) each group's bound at its unknowns, NaN elsewhere."""
    out = np.full(k, np.nan)
    for group, bound in zip(groups, bounds):
        out[group] = bound
    return out


def upper_bound(mdp: MDP, unknowns: Unknowns, counts: np.ndarray, theta: np.ndarray, model: PlayerModel,
                player: Player, rmax: float, best: float, V_fit: np.ndarray, group: list[int]) -> float:
    """The highest value the `group` of held unknowns can take together before the log likelihood falls by
    `FLAT_DROP` from `best` (its value at `theta`, whose soft values are `V_fit`), by bisection (`BOUND_STEPS`
    steps)."""
    low, high = -rmax, rmax
    # Each step's soft values start from the last step's, whose reward is half as far away as the one
    # before (on walled-24, 6.2 soft solves a step instead of 7.8 from the fit's values).
    V = V_fit
    for _ in range(BOUND_STEPS):
        middle = (low + high) / 2
        moved = theta.copy()
        moved[group] = middle
        got = log_likelihood(mdp, counts, unknowns.state_rewards(moved), model=model, player=player, V0=V,
                             gradient=False)
        V = got.plan.V
        low, high = (middle, high) if best - got.value < FLAT_DROP else (low, middle)
    return low


def jointly(held: np.ndarray) -> bool:
    """Whether the held bounds (`people_checks`) bounded the held unknowns together rather than one by one."""
    return int(np.sum(held)) > MAX_ONE_BY_ONE


def note_of_bounds(unknowns: Unknowns, upper: np.ndarray, held: np.ndarray) -> Note:
    """The note naming the held rewards and their upper bounds (k,)."""
    named = "; ".join(f"{label} {value:.3g}" for label, value, on in zip(unknowns.labels, upper, held) if on)
    how = "all together" if jointly(held) else "each alone"
    return Note("unreached", f"not bounded below by the data (no recorded action can lead there), held at the "
                             f"lowest reward {{rmax}} allows; the data allow at most ({how}): {named}")
