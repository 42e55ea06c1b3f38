"""Export and the Gymnasium environment, against the work they cannot avoid, in the same process.

- `careful export` (CSV, Minari) against reading the same recording, which every export does first.
- `CarefulEnv.step` against `MDP.move`, the sampler it wraps.

Run: .venv/bin/python -m bench.bench_export  (or `make bench` for every benchmark)
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from bench.timing import best_of
from irl_core.players.experts import boltzmann_policy, expert_name, rollouts, write_rollouts
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.export import write_csv, write_minari
from irl_core.worlds.env import CarefulEnv
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def main(episodes: int = 2000, steps: int = 20_000) -> None:
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    result = rollouts(mdp, boltzmann_policy(mdp, beta=0.5), episodes=episodes, seed=0)
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        path = folder / "b.jsonl"
        write_rollouts(path, mdp, result, player=expert_name("boltzmann", 0.5), seed=0)
        os.environ["MINARI_DATASETS_PATH"] = str(folder / "minari")
        read = best_of(3, lambda: read_recording(path))
        recording = read_recording(path)
        runs = iter(range(1000))
        csv = best_of(3, lambda: write_csv(folder / f"{next(runs)}.csv", [recording]))
        minari = best_of(1, lambda: write_minari(f"bench-v{next(runs)}", [recording], description="bench"))
    print(f"export of {episodes} episodes ({result.state.size} steps) on paper:")
    print(f"  read the recording {read:8.3f} s")
    print(f"  write CSV          {csv:8.3f} s   ratio to reading {csv / read:.2f}")
    print(f"  write Minari (hdf5){minari:8.3f} s   ratio to reading {minari / read:.2f}"
          f"  ({minari / episodes * 1000:.1f} ms per episode)")

    env = CarefulEnv("paper")
    rng = np.random.default_rng(0)
    actions = rng.integers(mdp.n_actions, size=steps)

    def env_steps() -> None:
        env.reset(seed=0)
        for a in actions:
            if env.step(a)[2:4] != (False, False):
                env.reset()

    def mdp_moves() -> None:
        s = mdp.state_of[(0, 0)]
        for a in actions:
            s, _ = mdp.move(s, int(a), rng)
            if not mdp.nonterminal[s]:
                s = mdp.state_of[(0, 0)]

    stepped, moved = best_of(3, env_steps), best_of(3, mdp_moves)
    print(f"{steps} steps on paper:")
    print(f"  CarefulEnv.step    {stepped / steps * 1e6:8.1f} us per step")
    print(f"  MDP.move           {moved / steps * 1e6:8.1f} us per step")
    print(f"  ratio env / move = {stepped / moved:.2f}")


if __name__ == "__main__":
    main()
