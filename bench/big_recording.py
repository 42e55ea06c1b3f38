"""A big recording for the reader's and the fit's memory benchmarks: a noisy expert's episodes on paper."""

from __future__ import annotations

from pathlib import Path


def write_big_recording(folder: str | Path, *, episodes: int) -> tuple[Path, float]:
    """``folder/big.jsonl``: `episodes` episodes of a Boltzmann expert (beta 0.1) on paper; returns it and its MB."""
    from irl_core.players.experts import boltzmann_policy, expert_name, simulate_to_file
    from irl_core.worlds.mdp import build_mdp
    from irl_core.worlds.world import BUILTIN_WORLDS

    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    path = Path(folder) / "big.jsonl"
    simulate_to_file(path, mdp, boltzmann_policy(mdp, beta=0.1), episodes=episodes, seed=0,
                     player=expert_name("boltzmann", 0.1))
    return path, path.stat().st_size / 2**20
