"""The fitting stages of the scaling benchmark: an `lp` fit with special cells, and its intervals."""

from __future__ import annotations

from irl_core.demonstrations import Demonstrations
from irl_core.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.irl import fit
from irl_core.mdp import MDP


def demonstrations_for(mdp: MDP, *, episodes: int, seed: int) -> Demonstrations:
    """Optimal episodes of `mdp`, as counts."""
    return demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed))


def fit_stage(demos: Demonstrations, *, intervals: bool) -> None:
    """The lp fit with special cells; with `intervals`, tied per symbol (cliff, goal), so that the
    number of interval LPs (4) stays the same at every size and the table shows the LP's growth."""
    fit(demos, method="lp", reward_cells="special", tie=intervals, intervals=intervals)
