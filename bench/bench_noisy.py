"""Noisy experts: how long maxent (beta estimated) and its bootstrap intervals take.

* bootstrap: `careful fit --intervals` on 40 Boltzmann episodes of `mud` (tied, rmax 5000,
  maxent with beta estimated, 200 resamples across the cores) against one such fit without
  intervals. Target: at most 25x on 2 cores.
* maxent per fit: one maxent fit (beta 1, the paper's baseline) on `paper` from 1,000
  Boltzmann episodes against one soft value iteration of `paper` (planning.soft_value_iteration,
  to its default tolerance), the planning a likelihood evaluation would need without soft
  policy iteration.

Run: .venv/bin/python -m bench bench_noisy
"""

from __future__ import annotations

import os

from bench.timing import best_of
from irl_core.irl import FitOptions, fit
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import soft_value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS


def boltzmann(name: str, *, beta: float, episodes: int, seed: int):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    return demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=beta), episodes=episodes, seed=seed))


def main() -> None:
    cores = os.cpu_count()
    demos = boltzmann("mud", beta=0.5, episodes=40, seed=0)
    options = FitOptions(method="maxent", beta="auto", tie=True, rmax=5000.0)
    one = best_of(3, lambda: fit(demos, options))
    boot = best_of(1, lambda: fit(demos, options, intervals=True, resamples=200))
    print(f"mud, 40 Boltzmann episodes, tied, beta estimated ({cores} cores):")
    print(f"  one maxent fit          {one * 1000:8.1f} ms")
    print(f"  with 200 resamples      {boot * 1000:8.1f} ms   {boot / one:5.1f}x one fit (target <= 25x)")

    paper = boltzmann("paper", beta=1.0, episodes=1000, seed=0)
    per_fit = best_of(3, lambda: fit(paper, method="maxent", beta=1.0))
    mdp = paper.mdp
    soft = best_of(3, lambda: soft_value_iteration(mdp, beta=1.0))
    print("paper, 1,000 Boltzmann episodes, beta 1, per-cell unknowns:")
    print(f"  one maxent fit          {per_fit * 1000:8.1f} ms")
    print(f"  one soft value iteration{soft * 1000:8.1f} ms   maxent = {per_fit / soft:5.1f}x")


if __name__ == "__main__":
    main()
