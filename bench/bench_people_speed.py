"""The default fit for people against the paper's maxent expert, on the same recordings in one process.

Two measurements, each a ratio against a baseline run beside it (these machines are shared: ratios, not
seconds, compare across runs):

* `mud`: one default fit (`player_model` chosen by held-out episodes, a fit check, 200 resamples) of 30
  `loose` person-like episodes, against the same fit with ``player_model="boltzmann"`` (maxent with beta
  estimated: the default for noisy play before the people model). Target: at most 3x.
* `--big`: point fits (no intervals) of 100 Boltzmann episodes on the generated cliff worlds of
  `bench/worlds.py` (16x16, 32x32, 64x64; one unknown per cell), the people model against maxent with beta
  estimated; it prints whether each converged and its time in soft value iterations of the same world
  (one `planning.soft_value_iteration` to convergence; target: within 30).

Run: .venv/bin/python -m bench bench_people_speed [--big]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import partial
from typing import TypeVar

import numpy as np

from bench.worlds import cliff_world
from irl_core.irl import fit
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.players.person_like import person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import soft_value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS

T = TypeVar("T")


def _timed(call: Callable[[], T]) -> tuple[float, T]:
    started = time.perf_counter()
    out = call()
    return time.perf_counter() - started, out


def mud(pairs: int = 2) -> None:
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "loose").choose, episodes=30,
                                            rng=np.random.default_rng([0, 7])))
    people, baseline = [], []
    for _ in range(pairs):
        t, result = _timed(lambda: fit(demos, intervals=True, resamples=200))
        people.append(t)
        t, _ = _timed(lambda: fit(demos, intervals=True, resamples=200, player_model="boltzmann"))
        baseline.append(t)
    ratio = min(people) / min(baseline)
    print(f"mud, 30 loose episodes, 200 resamples: people ({result.player_model}) {min(people):.1f} s, "
          f"boltzmann {min(baseline):.1f} s: {ratio:.2f}x (target at most 3x)")


def big(sizes: tuple[int, ...] = (16, 32, 64)) -> None:
    for size in sizes:
        mdp = build_mdp(cliff_world(size, size))
        demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=0.5), episodes=100, seed=0))
        planning, _ = _timed(partial(soft_value_iteration, mdp, beta=1.0))
        t_people, people = _timed(partial(fit, demos, player_model="person"))
        t_maxent, maxent = _timed(partial(fit, demos, method="maxent", beta="auto"))
        print(f"{size}x{size}: people {t_people:.1f} s ({people.status}, {t_people / planning:.1f} soft value "
              "iterations of the world), "
              f"maxent beta auto {t_maxent:.1f} s ({maxent.status}): {t_people / t_maxent:.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_people_speed", description=__doc__.split("\n\n")[0])
    parser.add_argument("--big", action="store_true", help="also the generated 16x16 to 64x64 worlds")
    args = parser.parse_args()
    mud()
    if args.big:
        big()


if __name__ == "__main__":
    main()
