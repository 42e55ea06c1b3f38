"""What a recorded session says at a glance: outcomes, scores, and carefulness by danger.

The paper's claim in one table: a careful expert's carefulness rises as the nearest
terminal cell (the cliff, the goal) gets closer.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from irl_core.recordings.demonstrations import Recording
from irl_core.recordings.lines import EpisodeEnd
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import World


def distance_to_terminal(world: World) -> dict[tuple[int, int], int]:
    """Grid steps (breadth first, around walls) from each cell to the nearest terminal cell.

    Cells that cannot reach a terminal cell are left out.
    """
    mdp = build_mdp(world)
    distance = {cell: 0 for cell in mdp.cells if world.symbol(cell) in world.terminal}
    frontier = list(distance)
    while frontier:
        nxt = []
        for cell in frontier:
            for n in mdp.neighbour[mdp.state_of[cell]]:
                other = mdp.cells[n] if n < len(mdp.cells) else None
                if other is not None and other not in distance:
                    distance[other] = distance[cell] + 1
                    nxt.append(other)
        frontier = nxt
    return distance


@dataclass(frozen=True)
class SessionSummary:
    """Episodes, outcomes and carefulness of one recording.

    Attributes:
        episodes: number of episodes (finished or not).
        outcomes: episodes per `outcome_code`: a terminal symbol, "quit", "step_limit", "unfinished".
        final_score: the score after the last step or episode end (None if nothing was played).
        steps: number of steps.
        slips: number of steps that slipped.
        carefulness_by_distance: distance to the nearest terminal cell -> (mean carefulness, steps); on a time
            world the mean hold in ms (a time world's care) instead of a mean level.
    """

    episodes: int
    outcomes: dict[str, int]
    final_score: float | None
    steps: int
    slips: int
    carefulness_by_distance: dict[int, tuple[float, int]]


def outcome_code(end: EpisodeEnd | None) -> str:
    """How an episode ended, as data: its terminal symbol ("G", "C", ...), "quit",
    "step_limit", or "unfinished" (no end recorded). The render layer words it."""
    if end is None:
        return "unfinished"
    return (end.terminal_symbol or "?") if end.outcome == "terminal" else end.outcome


def summarise(recording: Recording, *, distances: dict[tuple[int, int], int] | None = None) -> SessionSummary:
    """The session at a glance, from the recording's step columns (no `Step` is built per step).

    `distances`: `distance_to_terminal` of the recording's world, when the caller has it already.
    """
    world = recording.world
    ended = {end.episode: end for end in recording.episode_ends}
    outcomes = Counter(outcome_code(ended.get(e)) for e in recording.episodes)
    steps = recording.steps
    # The reader keeps lines in order, so the session's last line is its last step or its last end.
    candidates = []
    if steps:
        last = steps[-1]
        candidates.append(((last.episode, False, last.t), last.score))
    if recording.episode_ends:
        end = recording.episode_ends[-1]
        candidates.append(((end.episode, True, 0), end.score))
    last_score = max(candidates)[1] if candidates else None
    grid = np.full((world.rows, world.cols), -1, dtype=np.int64)
    for cell, d in (distance_to_terminal(world) if distances is None else distances).items():
        grid[cell] = d
    distance = grid[steps.column("row"), steps.column("col")]
    reached = distance >= 0
    counts = np.bincount(distance[reached], minlength=1)
    care = np.nan_to_num(steps.column("hold_ms")) if world.care == "time" else steps.column("level")
    totals = np.bincount(distance[reached], weights=care[reached], minlength=1)
    return SessionSummary(
        episodes=len(recording.episodes),
        outcomes=dict(outcomes),
        final_score=last_score,
        steps=len(steps),
        slips=int(steps.column("slipped").sum()),
        carefulness_by_distance={d: (float(totals[d] / counts[d]), int(counts[d])) for d in np.flatnonzero(counts).tolist()},
    )
