"""Carefulness against distance to danger: the plot a human study would show.

For each distance (grid steps to the nearest terminal cell, around walls, as
`irl_core.recordings.summary.distance_to_terminal` measures it) the mean carefulness level of the
demonstrated steps taken there, with a 95% interval for that mean (±1.96 standard errors,
counting steps as independent draws: steps of one episode are not, so read it as a guide).
A careful expert's line falls with distance: most careful next to the cliff.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.ticker import FuncFormatter, MaxNLocator

from careful_tui.render.figures.style import OKABE_ITO
from irl_core.recordings.summary import distance_to_terminal
from irl_core.worlds.mdp import MDP

Z_95 = 1.959964


@dataclass(frozen=True)
class CarefulnessByDistance:
    """Mean carefulness per distance to the nearest terminal cell.

    Attributes:
        distance: (n,) int, the distances with at least one step, ascending.
        mean: (n,) mean carefulness level of the steps taken at that distance.
        half_width: (n,) 1.96 standard errors of that mean (NaN with a single step).
        steps: (n,) how many steps were taken at that distance.
    """

    distance: np.ndarray
    mean: np.ndarray
    half_width: np.ndarray
    steps: np.ndarray


def state_distances(mdp: MDP) -> np.ndarray:
    """(S,) int grid steps from each state to the nearest terminal cell; -1 where none is reachable."""
    by_cell = distance_to_terminal(mdp.world)
    return np.array([by_cell.get(cell, -1) for cell in mdp.cells] + [-1] * (mdp.n_states - len(mdp.cells)))


def carefulness_by_distance(counts: np.ndarray, distance: np.ndarray, *, levels: int) -> CarefulnessByDistance:
    """Mean carefulness and its 95% half-width per distance, from action counts.

    Args:
        counts: (S, A) N(s, a), how often action a (= d * L + c - 1) was taken in state s.
        distance: (S,) int distance of each state to danger; states at -1 are left out.
        levels: L.
    """
    level = np.arange(counts.shape[1]) % levels + 1  # (A,)
    rows = []
    for d in np.unique(distance[distance >= 0]):
        taken = counts[distance == d].sum(axis=0)  # (A,) steps per action at this distance
        n = taken.sum()
        if n == 0:
            continue
        mean = float(taken @ level / n)
        variance = float(taken @ (level - mean) ** 2 / (n - 1)) if n > 1 else np.nan
        rows.append((int(d), mean, Z_95 * np.sqrt(variance / n), int(n)))
    distance_, mean_, half_, steps_ = (np.array(column) for column in zip(*rows)) if rows else ([],) * 4
    return CarefulnessByDistance(np.asarray(distance_, dtype=int), np.asarray(mean_, dtype=float),
                                 np.asarray(half_, dtype=float), np.asarray(steps_, dtype=int))


@dataclass(frozen=True)
class HoldsByDistance:
    """A time world's care per distance to the nearest terminal cell: the holds' geometric mean.

    Attributes:
        distance: (n,) int, the distances with at least one recorded hold, ascending.
        geometric_mean: (n,) the geometric mean hold (ms) of the steps taken there.
        low, high: (n,) its 95% interval (±1.96 standard errors of the mean log hold; NaN with one hold).
        steps: (n,) how many holds.
    """

    distance: np.ndarray
    geometric_mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    steps: np.ndarray


def holds_by_distance(hold_steps: np.ndarray, distance: np.ndarray) -> HoldsByDistance:
    """The geometric mean hold and its 95% interval per distance, as `carefulness_by_distance` for levels.

    Args:
        hold_steps: (m, 5) `Demonstrations.hold_steps` (state, direction, hold_ms, slipped, episode row).
        distance: (S,) int distance of each state to danger; states at -1 are left out.
    """
    at = distance[hold_steps[:, 0].astype(int)] if hold_steps.size else np.zeros(0, dtype=int)
    logs_all = np.log(np.maximum(hold_steps[:, 2], 1.0))  # a hold under 1 ms counts as 1 ms (no log of 0)
    distances = np.unique(at[at >= 0])
    means, halves, steps = np.zeros(distances.size), np.zeros(distances.size), np.zeros(distances.size, dtype=int)
    for i, d in enumerate(distances):
        logs = logs_all[at == d]
        means[i], steps[i] = logs.mean(), logs.size
        halves[i] = Z_95 * logs.std(ddof=1) / np.sqrt(logs.size) if logs.size > 1 else np.nan
    return HoldsByDistance(distances.astype(int), np.exp(means), np.exp(means - halves), np.exp(means + halves),
                           steps)


def draw_holds_by_distance(ax: Axes, data: HoldsByDistance, *, colour: str, title: str | None = None) -> None:
    """Geometric mean hold (y, ms, log scale) against distance to danger (x) on `ax`, with its 95% interval."""
    mean = data.geometric_mean
    error = np.nan_to_num([mean - data.low, data.high - mean])
    ax.errorbar(data.distance, mean, yerr=error, fmt="o-", color=colour, markersize=3, capsize=2,
                elinewidth=0.8, linewidth=1.0)
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))  # 100, not 10^2: read as ms
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    if title:
        ax.set_title(title, pad=3)


def draw_carefulness(ax: Axes, series: Sequence[tuple[str, CarefulnessByDistance]], *, levels: int,
                     title: str | None = None) -> None:
    """Mean carefulness (y, 1..L) against distance to danger (x) on `ax`, one line per series."""
    for i, (label, data) in enumerate(series):
        ax.errorbar(data.distance, data.mean, yerr=np.nan_to_num(data.half_width), fmt="o-",
                    color=OKABE_ITO[(1 + i) % len(OKABE_ITO)], markersize=3, capsize=2,
                    elinewidth=0.8, linewidth=1.0, label=label)
    ax.set_ylim(0.5, levels + 0.5)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True, nbins=6))
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("steps to the nearest terminal cell")
    ax.set_ylabel("mean carefulness level")
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    if title:
        ax.set_title(title, pad=3)
    if series:
        ax.legend(title="mean ± 95% confidence interval", title_fontsize=6, loc="upper right")

