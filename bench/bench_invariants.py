"""The rules every answer keeps, counted over many random fits on every path (issue target: 0 violations
over at least 2,000 fits, and over every recording the tests and benches hold).

Each fit draws a small world (2-4 rows, 3-5 columns, one goal, cliff, mud and walls at random, 1 or 3
levels, a move costing 0 or 1, halving slip or none), a player and a path:

* lp (per cell or tied) on optimal play;
* loss on optimal or Boltzmann play;
* maxent with beta given (0.5) or estimated, as Boltzmann players;
* each model of people (ends, hand, person, naive, auto) on loose, timed and hasty person-like play;
* the default fit on one-level worlds, relative or with the goal known;
* timing on `mud-time` with holding that costs 0 or 5 per second.

Then every well-formed recording in the repository (tests/corpus/recordings, recordings/), fitted by
default. `invariant_violations` (irl_core/irl/intervals/honest.py) judges each fit; the counts are per
path, with the first violations printed whole. Fits that careful refuses (an lp without a solution) are
counted apart: a refusal is an answer, not a violation.

Run: .venv/bin/python -m bench bench_invariants [--fits 2000] [--resamples 20] [--seed 0]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from irl_core.errors import InputError
from irl_core.irl import fit
from irl_core.irl.intervals.honest import invariant_violations
from irl_core.players.experts import Chooser, boltzmann_policy, demonstrations_of, optimal_policy, rollouts, simulate_to_file
from irl_core.players.person_like import person_like
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World

PATHS = ("lp", "loss", "maxent", "people", "one-level", "timing")
MODELS = ("ends", "hand", "person", "naive", "auto")
ROOT = Path(__file__).resolve().parent.parent


def random_world(rng: np.random.Generator, *, levels: int | None = None) -> World:
    """A world as the property tests draw them; redrawn until the world accepts the layout."""
    while True:
        rows, cols = int(rng.integers(2, 5)), int(rng.integers(3, 6))
        cells = list(rng.choice(list(".....UC#"), size=rows * cols))
        cells[int(rng.integers(rows * cols))] = "G"
        layout = "\n".join("".join(cells[r * cols:(r + 1) * cols]) for r in range(rows)) + "\n"
        rewards = {"G": float(rng.choice([10.0, 100.0])), "C": float(rng.choice([-100.0, -1000.0])),
                   "U": float(rng.choice([-3.0, -30.0]))}
        try:
            return World(name="drawn", layout=layout, rewards=rewards,
                         levels=levels or int(rng.choice([1, 3])), cost_per_level=float(rng.choice([0.0, 1.0])),
                         slip="halving" if rng.integers(2) else "none", max_steps=60)
        except ValueError:
            continue


def play(world: World, player: str, episodes: int, seed: int):
    mdp = build_mdp(world)
    policy: np.ndarray | Chooser
    if player == "optimal":
        policy = optimal_policy(mdp)
    elif player == "boltzmann":
        policy = boltzmann_policy(mdp, beta=0.5)
    else:
        policy = person_like(mdp, player).choose
    return demonstrations_of(mdp, rollouts(mdp, policy, episodes=episodes, seed=seed))


def one_fit(path: str, rng: np.random.Generator, options: dict, folder: Path):
    """One random fit on `path`: (what was fitted, the result)."""
    episodes, seed = int(rng.integers(3, 21)), int(rng.integers(2**16))
    if path == "lp":
        world, tie = random_world(rng), bool(rng.integers(2))
        return f"lp tie={tie}", fit(play(world, "optimal", episodes, seed), method="lp", tie=tie, **options)
    if path == "loss":
        player = str(rng.choice(["optimal", "boltzmann"]))
        return f"loss {player}", fit(play(random_world(rng), player, episodes, seed), method="loss", tie=True,
                                     **options)
    if path == "maxent":
        beta: str | float = "auto" if rng.integers(2) else 0.5
        return f"maxent beta={beta}", fit(play(random_world(rng), "boltzmann", episodes, seed), method="maxent",
                                         beta=beta, tie=bool(rng.integers(2)), player_model="boltzmann",
                                         **options)
    if path == "people":
        player, model = str(rng.choice(["loose", "timed", "hasty"])), str(rng.choice(MODELS))
        return f"{model} on {player}", fit(play(random_world(rng, levels=3), player, episodes, seed),
                                           method="maxent", tie=True, player_model=model, **options)
    if path == "one-level":
        known = (("G", 100.0),) if rng.integers(2) else ()
        return f"one level known={bool(known)}", fit(play(random_world(rng, levels=1), "loose", episodes, seed),
                                                     tie=True, known=known, **options)
    cost = float(rng.choice([0.0, 5.0]))
    world = BUILTIN_WORLDS["mud-time"].model_copy(update={
        "cost_per_second": cost, "rewards": {"C": float(rng.choice([-300.0, -1000.0])), "G": 100.0, "U": -30.0}})
    mdp = build_mdp(world)
    file = folder / f"timing-{seed}-{episodes}.jsonl"
    file.unlink(missing_ok=True)
    simulate_to_file(file, mdp, person_like(mdp, "timing").choose, episodes=episodes + 1, seed=seed,
                     player="timing")
    return f"timing cost={cost:g}", fit(Demonstrations.read([file]), method="maxent", tie=True, **options)


def recordings() -> list[Path]:
    """Every recording the repository holds that reads cleanly (the corpus's bad files are refused, as they
    should be, and not counted)."""
    files = sorted((ROOT / "tests" / "corpus" / "recordings").glob("*.jsonl")) + sorted(
        (ROOT / "recordings").rglob("*.jsonl"))
    good = []
    for file in files:
        try:
            Demonstrations.read([file])
        except InputError:
            continue
        good.append(file)
    return good


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m bench bench_invariants", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False)
    parser.add_argument("--fits", type=int, default=300, help="random fits in all, spread over the paths "
                                                              "(default 300; the target is measured at 2000)")
    parser.add_argument("--resamples", type=int, default=20, help="bootstrap resamples per fit (default 20)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    options = {"intervals": True, "resamples": args.resamples, "rmax": 1000.0, "workers": 1}
    rng = np.random.default_rng(args.seed)
    fits: Counter[str] = Counter()
    refused: Counter[str] = Counter()
    broken: Counter[str] = Counter()
    shown: list[str] = []
    start = time.perf_counter()

    def judge(where: str, what: str, result) -> None:
        fits[where] += 1
        problems = invariant_violations(result)
        if problems:
            broken[where] += 1
            print(f"  violation, fit {sum(fits.values())} {where} ({what}): " + "; ".join(problems), flush=True)
            if len(shown) < 10:
                shown.append(f"  {where} ({what}): " + "; ".join(problems))

    with tempfile.TemporaryDirectory() as tmp:
        for index in range(args.fits):
            path = PATHS[index % len(PATHS)]
            try:
                what, result = one_fit(path, rng, options, Path(tmp))
            except InputError:
                refused[path] += 1
                continue
            judge(path, what, result)
            if (index + 1) % 100 == 0:
                print(f"  {index + 1} fits, {sum(broken.values())} with a violation, "
                      f"{time.perf_counter() - start:.0f} s", flush=True)
    for file in recordings():
        try:
            result = fit(Demonstrations.read([file]), **options)
        except InputError:
            refused["recordings"] += 1
            continue
        judge("recordings", file.name, result)

    print(f"{sum(fits.values())} fits judged, {sum(refused.values())} refused by careful "
          f"({time.perf_counter() - start:.0f} s):")
    for where in (*PATHS, "recordings"):
        print(f"  {where:<11} {fits[where]:5d} fits  {broken[where]:3d} with a violation  "
              f"{refused[where]:3d} refused")
    print(f"violations: {sum(broken.values())} (target 0)")
    print("\n".join(shown))


if __name__ == "__main__":
    main()
