"""Vectorised rollouts against a plain per-episode loop, in the same process.

Run: .venv/bin/python -m bench.bench_rollouts  (or `make bench` for every benchmark)
"""

from __future__ import annotations

import numpy as np

from bench.timing import best_of
from irl_core.players.experts import optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def per_episode_loop(mdp, policy, *, episodes: int, seed: int) -> int:
    """The obvious implementation: one Python loop per episode and per step."""
    rng = np.random.default_rng(seed)
    starts = [mdp.state_of[cell] for cell in mdp.world.start_cells]
    steps = 0
    for _ in range(episodes):
        s = starts[rng.integers(len(starts))]
        for _ in range(mdp.world.max_steps):
            a = rng.choice(mdp.n_actions, p=policy[s])
            s, _ = mdp.move(s, a, rng)
            steps += 1
            if not mdp.nonterminal[s]:
                break
    return steps


def main(episodes: int = 10_000) -> None:
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    policy = optimal_policy(mdp)
    vectorised = best_of(5, lambda: rollouts(mdp, policy, episodes=episodes, seed=0))
    loop = best_of(1, lambda: per_episode_loop(mdp, policy, episodes=episodes, seed=0))
    print(f"rollouts, {episodes} episodes on paper:")
    print(f"  vectorised      {vectorised * 1000:8.1f} ms")
    print(f"  per-episode loop{loop * 1000:8.1f} ms")
    print(f"  ratio vectorised / loop = {vectorised / loop:.3f}  ({loop / vectorised:.0f}x faster)")


if __name__ == "__main__":
    main()
