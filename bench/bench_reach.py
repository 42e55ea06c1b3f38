"""Reach worlds' fit, measured against the issue's first target (docs/reach.md, "Validation").

- ``maximiser``: the expected-gain maximiser (`careful simulate --policy optimal`), 100 trials, on each of
  `reach-mild`, `reach` and `reach-severe`, 20 seeds each, fitted as `careful fit` does (spread law not given):
  the fitted penalty within 20% of the truth, its interval covering the truth, the target's covering, the
  three penalties in the right order in every seed. Again with the target's points known (``--known G=100``).
- ``soft``: the soft-optimal player (beta 0.2, the fit's own model), the same counts.
- ``hand``: the person-like ``hand`` (`careful simulate --policy hand`: aim noise, timing noise, lapses; none
  of the fit's models), the same counts: how often the intervals hold the truth on a player the fit does not
  model.
- ``fixed``: the paper's claim. The soft-optimal player on `reach` (-500) and `reach-severe` (-5000) with its
  duration free against the same worlds with the duration fixed (no care to choose: the world's limits
  narrowed to one duration, at FIXED_MS each), 20 seeds each: in how many seeds the two penalties' intervals
  do not overlap (told apart). With the target unknown and with it known (G = 100).
- ``time``: the wall time of one fit of 200 soft-optimal trials with intervals (spread law fitted), best of 3.

    python -m bench.bench_reach --seeds 20 --trials 100 [--parts maximiser,soft,hand,fixed,time]

A line of JSON per world and player as it finishes; the summary last.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from irl_core.reach.fit import RMAX, ReachFit, fit_reaches
from irl_core.reach.gain import best_choice, choice_grid, expected_gain
from irl_core.reach.players import reacher, simulate_reaches_to_file
from irl_core.recordings.reach_reader import read_reaches
from irl_core.worlds.reach import REACH_WORLDS, ReachWorld

WORLDS = ("reach-mild", "reach", "reach-severe")
SOFT_BETA = 0.2
PARTS = ("maximiser", "soft", "hand", "fixed", "time")
# The fixed durations of ``fixed``: the free maximiser's own on `reach` (the longest allowed) and the
# geometric middle of the limits (a quicker reach, more scatter).
FIXED_MS = (1500.0, 474.0)


def fixed_world(world: ReachWorld, duration_ms: float) -> ReachWorld:
    """`world` with its duration limits narrowed to `duration_ms` (within a thousandth): no care to choose."""
    return ReachWorld.model_validate({**world.model_dump(), "name": f"{world.name}-{duration_ms:g}ms",
                                      "min_ms": duration_ms * 0.999, "max_ms": duration_ms})


def fitted(folder: Path, name: str, policy: str, *, trials: int, seed: int, known: dict[str, float],
           world: ReachWorld | None = None) -> ReachFit:
    world = world or REACH_WORLDS[name]
    path = folder / f"{world.name}-{policy}-{seed}.jsonl"
    if not path.exists():
        simulate_reaches_to_file(path, world, reacher(world, policy, beta=SOFT_BETA), trials=trials, seed=seed)
    return fit_reaches(read_reaches([path])[0], known=known)


def told_apart(folder: Path, *, seeds: int, trials: int, known: dict[str, float]) -> dict:
    """In how many seeds the soft-optimal player's fitted intervals of `reach`'s and `reach-severe`'s penalty
    do not overlap, with the duration free and fixed at each of FIXED_MS."""
    rows = {}
    for label, duration in (("free", None), *((f"fixed {ms:g} ms", ms) for ms in FIXED_MS)):
        apart, covered, whole, widths = 0, 0, 0, []
        for seed in range(seeds):
            pair = []
            for name in ("reach", "reach-severe"):
                world = REACH_WORLDS[name] if duration is None else fixed_world(REACH_WORLDS[name], duration)
                pair.append(fitted(folder, name, "boltzmann", trials=trials, seed=seed, known=known, world=world))
            (low_500, high_500), (low_5000, high_5000) = (fit.interval["C"] for fit in pair)
            apart += high_5000 < low_500 or high_500 < low_5000
            covered += (low_500 <= -500 <= high_500) + (low_5000 <= -5000 <= high_5000)
            widths += [high_500 - low_500, high_5000 - low_5000]
            whole += sum(fit.interval["C"][0] <= -RMAX and fit.interval["C"][1] >= RMAX for fit in pair)
        rows[label] = {"told_apart": apart / seeds, "covered": covered / (2 * seeds), "whole_range": whole / (2 * seeds),
                       "median_width": float(np.median(widths))}
        print(json.dumps({"part": "fixed", "known": known, "duration": label, **rows[label]}), flush=True)
    return rows


def measure(folder: Path, policy: str, *, seeds: int, trials: int, known: dict[str, float]) -> dict:
    penalties: dict[str, list[float]] = {name: [] for name in WORLDS}
    rows = {}
    for name in WORLDS:
        truth = REACH_WORLDS[name].points
        fits = [fitted(folder, name, policy, trials=trials, seed=seed, known=known) for seed in range(seeds)]
        penalties[name] = [fit.reward["C"] for fit in fits]
        rows[name] = {
            "penalty_median": float(np.median(penalties[name])),
            "within_20%": sum(abs(fit.reward["C"] / truth["C"] - 1) <= 0.2 for fit in fits) / seeds,
            "penalty_covered": sum(fit.interval["C"][0] <= truth["C"] <= fit.interval["C"][1] for fit in fits) / seeds,
            "target_covered": sum(fit.interval["G"][0] <= truth["G"] <= fit.interval["G"][1] for fit in fits) / seeds,
            "interval_kind": fits[0].interval_kind,
            # intervals that are the whole range (the points' scale not pinned): they cover, and say nothing
            "whole_range": sum(fit.interval["C"][0] <= -RMAX and fit.interval["C"][1] >= RMAX for fit in fits) / seeds,
            "penalty_interval_median": [float(np.median([fit.interval["C"][i] for fit in fits])) for i in (0, 1)],
        }
        print(json.dumps({"policy": policy, "known": known, "world": name, **rows[name]}), flush=True)
    ordered = sum(penalties["reach-mild"][s] > penalties["reach"][s] > penalties["reach-severe"][s]
                  for s in range(seeds)) / seeds
    return {"worlds": rows, "ordered_in": ordered}


def fit_time(folder: Path, *, trials: int = 200, repeats: int = 3) -> float:
    world = REACH_WORLDS["reach"]
    path = folder / "timed.jsonl"
    simulate_reaches_to_file(path, world, reacher(world, "boltzmann", beta=SOFT_BETA), trials=trials, seed=99)
    reaches = read_reaches([path])[0]
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fit_reaches(reaches)
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_reach", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--trials", type=int, default=100)
    parser.add_argument("--parts", default=",".join(PARTS), help=f"which to measure, of {', '.join(PARTS)}")
    args = parser.parse_args()
    parts = args.parts.split(",")
    for name in WORLDS:
        world = REACH_WORLDS[name]
        aim, duration = best_choice(choice_grid(world), list(world.points.values()))
        print(json.dumps({"world": name, "best_aim": aim.tolist(), "best_ms": round(duration),
                          "expected_gain": round(float(expected_gain(world, aim, duration)), 2)}), flush=True)
    summary: dict[str, object] = {}
    with tempfile.TemporaryDirectory() as folder:
        for part, policy in (("maximiser", "optimal"), ("soft", "boltzmann"), ("hand", "hand")):
            # The hand's coverage is measured as careful fit runs on it, the target unknown.
            for known in (({}, {"G": 100.0}) if part != "hand" else ({},)) if part in parts else ():
                key = f"{policy}{' G known' if known else ''}"
                summary[key] = measure(Path(folder), policy, seeds=args.seeds, trials=args.trials, known=known)
        for known in ({}, {"G": 100.0}) if "fixed" in parts else ():
            summary[f"fixed against free{' G known' if known else ''}"] = told_apart(
                Path(folder), seeds=args.seeds, trials=args.trials, known=known)
        if "time" in parts:
            summary["fit_seconds_200_trials"] = round(fit_time(Path(folder)), 2)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
