"""The default fit for noisy play on big worlds: does it converge, and is its reward safe to plan for?

Issue 32's world: 24x24 with a wall and a patch of mud (`walled_world`), and the generated 64x64 cliff
world of `bench/worlds.py`; 100 episodes of a Boltzmann expert (beta 1, the model's own special case),
fitted by the default `careful fit` (method auto: maxent with the model of the player chosen on held-out
episodes, one reward per special cell). Per world it prints: the fit's status and time, as a multiple of
one value iteration of the same world timed in the same process (target <= 150x), how often an agent that
plans for the fitted reward falls off the cliff (target <= 1%; the optimum's rate beside it), the fit
check on the data (in-model data: it should pass), and how many cliff cells the fit pins, bounds on one
side, or leaves unreached.

Run: .venv/bin/python -m bench bench_people_big [--sizes 24,64] [--workers N] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np

from bench.timing import best_of
from bench.worlds import cliff_world
from irl_core.irl import fit
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import World

TARGET_VI = 150.0
TARGET_FALL = 0.01


def walled_world(size: int = 24) -> World:
    """`size` x `size`: the bottom row a cliff from column 1 with the goal at its end, a wall down the middle
    with a gap at the top and at the bottom, and a 4x4 patch of mud left of it."""
    rows = [["."] * size for _ in range(size)]
    rows[-1] = ["."] + ["C"] * (size - 2) + ["G"]
    for r in range(4, size - 4):
        rows[r][size // 2] = "#"
    for r in range(size // 3, size // 3 + 4):
        for c in range(size // 6, size // 6 + 4):
            rows[r][c] = "U"
    layout = "\n".join("".join(row) for row in rows) + "\n"
    return World(name=f"walled-{size}", layout=layout, levels=14, rewards={"C": -1000.0, "G": 100.0, "U": -30.0})


def world_for(size: int) -> World:
    return walled_world(size) if size < 64 else cliff_world(size, size)


def measure(size: int, *, episodes: int = 100, seed: int = 0, workers: int | None = None) -> dict:
    mdp = build_mdp(world_for(size))
    one_vi = best_of(3, lambda: value_iteration(mdp))
    demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=1.0), episodes=episodes, seed=seed))
    start, cpu = time.perf_counter(), _cpu_seconds()
    result = fit(demos, workers=workers)
    seconds, cpu = time.perf_counter() - start, _cpu_seconds() - cpu
    codes = [note.code for note in result.notes]
    cliff = [i for i, label in enumerate(result.unknowns.labels) if label.startswith("C")]
    unpinned = [str(note) for note in result.notes if note.code in ("one_sided", "unreached")]
    return {
        "world": mdp.world.name, "states": mdp.n_states, "status": result.status, "seconds": seconds, "cpu_seconds": cpu,
        "vi_seconds": one_vi, "vi_ratio": seconds / one_vi, "player_model": result.player_model,
        "agent_cliff": result.evaluation.agent.ends.get("C", 0.0),
        "optimal_cliff": result.evaluation.optimal.ends.get("C", 0.0),
        "fit_check": None if result.fit_check is None else result.fit_check.passed,
        "cliff_cells": len(cliff),
        "cliff_at_bound": int(np.sum(np.abs(result.theta[cliff]) >= result.options.rmax * (1 - 1e-6))),
        "notes": codes, "unpinned": unpinned,
    }


def _cpu_seconds() -> float:
    """CPU seconds of this process and of its children that have ended (the fit's pools)."""
    mine, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return mine.ru_utime + mine.ru_stime + children.ru_utime + children.ru_stime


def line(row: dict) -> str:
    verdicts = [f"{'meets' if row['vi_ratio'] <= TARGET_VI else 'misses'} {TARGET_VI:g}x VI",
                f"{'meets' if row['agent_cliff'] <= TARGET_FALL else 'misses'} <= {TARGET_FALL:.0%} falls",
                f"fit check {'passed' if row['fit_check'] else 'failed' if row['fit_check'] is False else 'not run'}"]
    return (f"{row['world']} ({row['states']} states): {row['status']} in {row['seconds']:.1f} s = "
            f"{row['vi_ratio']:.0f}x one VI ({row['vi_seconds']:.3f} s; CPU {row['cpu_seconds']:.1f} s in all processes), "
            f"model {row['player_model']}; agent falls "
            f"{100 * row['agent_cliff']:.2f}% (optimum {100 * row['optimal_cliff']:.2f}%); "
            f"{row['cliff_at_bound']} of {row['cliff_cells']} cliff cells at the bound; " + "; ".join(verdicts))


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_people_big", description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="24,64", help="comma-separated sizes (24: the walled world)")
    parser.add_argument("--out", default=None, help="also write the rows as JSON lines here")
    parser.add_argument("--workers", type=int, default=None, help="processes for the fit (default: every core)")
    args = parser.parse_args()
    for size in (int(s) for s in args.sizes.split(",")):
        row = measure(size, workers=args.workers)
        print(line(row), flush=True)
        for text in row["unpinned"]:
            print(f"  {text[:300]}", flush=True)
        if args.out:
            with open(args.out, "a", encoding="utf-8") as out:
                out.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
