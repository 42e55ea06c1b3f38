"""What asking "should I stop?" before every soft Bellman solve costs a maxent fit.

* with a stop check: `fit_maxent` inside `stopping.stop_when` with a check like the fit view's
  (a worker's `is_cancelled`, an attribute read), against the same fit outside it (where the
  check finds no function to ask): the median ratio of back-to-back pairs, in alternating
  order. Target: under 1.02x. (On a loaded machine this ratio is as noisy as the machine.)
* the checks alone: how many checks one fit makes, times one check's cost (timed in a loop of
  100,000), as a share of the fit: what the checks cost against code without them, measured
  apart from the fit's noise.

On `mud` (40 Boltzmann episodes, beta estimated: the smallest evaluations, so the largest share)
and a 16x16 cliff world (20 optimal episodes, beta 1: sparse solves, as big worlds).

Run: .venv/bin/python -m bench bench_maxent_stop
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial

import numpy as np

from bench.fit_stage import demonstrations_for
from bench.worlds import cliff_world
from irl_core.irl import maxent
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.stopping import stop_if_asked, stop_when
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

PAIRS = {"mud, beta auto": 41, "cliff 16x16, beta 1": 15}
CHECKS_TIMED = 100_000


class Worker:
    """As a Textual worker: `is_cancelled` is read at every check."""

    is_cancelled = False


def seconds_per_check(worker: Worker) -> float:
    """One `stop_if_asked` with a check like the fit view's, timed in a loop of CHECKS_TIMED."""
    with stop_when(lambda: worker.is_cancelled):
        start = time.perf_counter()
        for _ in range(CHECKS_TIMED):
            stop_if_asked()
        return (time.perf_counter() - start) / CHECKS_TIMED


def timed_in_pairs(run: Callable[[], object], pairs: int, worker: Worker) -> tuple[float, list[float], list[float]]:
    """`run` timed `pairs` times plain and `pairs` times under a stop check like the fit view's,
    alternating which goes first: the median ratio checked/plain over the pairs, and both timings."""

    def timed() -> float:
        start = time.perf_counter()
        run()
        return time.perf_counter() - start

    plain, checked = [], []
    for pair in range(pairs):
        for with_check in (pair % 2 == 0, pair % 2 == 1):
            if with_check:
                with stop_when(lambda: worker.is_cancelled):
                    checked.append(timed())
            else:
                plain.append(timed())
    return float(np.median(np.array(checked) / np.array(plain))), plain, checked


def main() -> None:
    mud = build_mdp(BUILTIN_WORLDS["mud"])
    cliff = build_mdp(cliff_world(16, 16))
    cases: list[tuple[str, Demonstrations, float | str]] = [
        ("mud, beta auto", demonstrations_of(mud, rollouts(mud, boltzmann_policy(mud, beta=0.5), episodes=40, seed=0)),
         "auto"),
        ("cliff 16x16, beta 1", demonstrations_for(cliff, episodes=20, seed=0), 1.0),
    ]
    worker = Worker()
    for name, demos, beta in cases:
        unknowns = build_unknowns(demos.mdp, reward_cells="special", tie=False)

        one_fit = partial(maxent.fit_maxent, demos.mdp, unknowns, demos.counts, beta=beta, rmax=1000.0)

        ratio, plain, checked = timed_in_pairs(one_fit, PAIRS[name], worker)
        asked = [0]

        def counting(asked: list[int] = asked) -> bool:
            asked[0] += 1
            return worker.is_cancelled

        with stop_when(counting):
            maxent.fit_maxent(demos.mdp, unknowns, demos.counts, beta=beta, rmax=1000.0)
        per_check = seconds_per_check(worker)
        fit_time = float(np.median(plain))
        print(f"{name}: one maxent fit {fit_time * 1000:8.1f} ms (median of {len(plain)}), {asked[0]} checks")
        print(f"  with a stop check     {float(np.median(checked)) * 1000:8.1f} ms   {ratio:6.3f}x (median pair; "
              "target < 1.02x)")
        print(f"  the checks alone      {asked[0] * per_check * 1e6:8.1f} us   "
              f"{asked[0] * per_check / fit_time:8.5%} of the fit ({per_check * 1e9:.0f} ns a check)")


if __name__ == "__main__":
    main()
