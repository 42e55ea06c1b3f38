"""Laplace intervals against the bootstrap, on the same fits: coverage, width and time.

For each person-like player and world, N seeds of E episodes are fitted with the ``person`` model
(`fit_given_model`); each fit gets three 95% intervals per symbol (tied unknowns): the bootstrap
(`fit(...)`, 200 resamples of episodes, refitted), and the Laplace interval
(`irl_core.irl.people.laplace`) on the log and on the reward scale. Per (player, world, interval) it prints,
as a Markdown table, the share of seeds whose interval holds the world's reward, per symbol, the
median width per symbol, and the median seconds per fit's interval; the bootstrap's time over the
Laplace's is the speed-up (both measured here, in the same process).

Run: .venv/bin/python -m bench bench_laplace [--seeds N] [--episodes E] [--players ...] [--worlds ...]
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from irl_core.irl import FitOptions, fit
from irl_core.irl.choices import player_model
from irl_core.irl.people import fit_given_model, laplace_intervals
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.players.person_like import person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import load_world

RMAX = 5000.0
KINDS = ("bootstrap", "laplace log", "laplace reward")


def one(world_name: str, kind: str, episodes: int, seed: int) -> dict[str, tuple[np.ndarray, float]]:
    """Every interval kind's (k, 2) intervals and seconds for one seed."""
    mdp = build_mdp(load_world(world_name))
    unknowns = build_unknowns(mdp, tie=True)
    demos = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, kind).choose, episodes=episodes, seed=seed))
    out = {}
    started = time.perf_counter()
    booted = fit(demos, FitOptions(method="maxent", player_model="person", tie=True, intervals=True, resamples=200,
                                   seed=seed, rmax=RMAX), workers=1)
    out["bootstrap"] = (np.asarray(booted.intervals if booted.intervals is not None else np.full((unknowns.k, 2), np.nan)),
                        time.perf_counter() - started)
    fitted = fit_given_model(mdp, unknowns, demos.counts, model=player_model("person"), rmax=RMAX)
    for scale in ("log", "reward"):
        started = time.perf_counter()
        intervals = laplace_intervals(mdp, unknowns, demos.counts, fitted, rmax=RMAX, scale=scale)
        out[f"laplace {scale}"] = (intervals, time.perf_counter() - started)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--players", nargs="+", default=["loose", "timed", "hasty"])
    parser.add_argument("--worlds", nargs="+", default=["mud"])
    args = parser.parse_args()
    print(f"{args.seeds} seeds of {args.episodes} episodes, person model, 95% intervals per symbol")
    print("| player | world | interval | covered (per symbol) | median width | median s |")
    print("|---|---|---|---|---|---|")
    with ProcessPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        for world_name in args.worlds:
            mdp = build_mdp(load_world(world_name))
            unknowns = build_unknowns(mdp, tie=True)
            truth = unknowns.true_theta(mdp)
            for kind in args.players:
                runs = list(pool.map(one, *zip(*((world_name, kind, args.episodes, s) for s in range(args.seeds)))))
                for name in KINDS:
                    intervals = np.stack([run[name][0] for run in runs])
                    seconds = np.median([run[name][1] for run in runs])
                    held = (intervals[:, :, 0] <= truth) & (truth <= intervals[:, :, 1])
                    widths = np.median(intervals[:, :, 1] - intervals[:, :, 0], axis=0)
                    covered = " ".join(f"{s} {c:.0%}" for s, c in zip(unknowns.symbols, held.mean(axis=0)))
                    width = " ".join(f"{s} {w:.0f}" for s, w in zip(unknowns.symbols, widths))
                    print(f"| {kind} | {world_name} | {name} | {covered} | {width} | {seconds:.3f} |", flush=True)


if __name__ == "__main__":
    main()
