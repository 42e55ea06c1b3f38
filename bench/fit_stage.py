"""The fitting stages of the scaling benchmark: an `lp` fit with special cells, and its intervals."""

from __future__ import annotations

from irl_core.irl import fit
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import MDP


def demonstrations_for(mdp: MDP, *, episodes: int, seed: int) -> Demonstrations:
    """Optimal episodes of `mdp`, as counts."""
    return demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed))


def fit_stage(demos: Demonstrations, *, intervals: str | None) -> dict:
    """The lp fit with special cells; with `intervals` "cells", an interval per cell (2 LPs per
    non-ground cell), with "tied", per symbol (cliff, goal: 4 LPs at every size, so the table shows
    the LP's growth). Returns the rounds of row generation and the interval LPs answered."""
    heard = {"rounds": 0, "intervals": 0}

    def progress(stage: str, done: int, total: int | None) -> None:
        heard[stage] = done

    fit(demos, method="lp", reward_cells="special", tie=intervals == "tied", intervals=intervals is not None,
        progress=progress)
    return heard
