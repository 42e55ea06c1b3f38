"""What asking "should I stop?" costs a fit's evaluation, and how long it goes without asking.

After every fit, `evaluate` plans for the fitted reward and for the true one (policy iteration,
asking the stop check before every policy solve) and follows each plan to its ends (`policy_ends`,
asking before and after its sparse solves). On a 64x64 cliff world (`cliff_world(64, 64)`,
20 optimal episodes from `demonstrations_for`), with the reward of a maxent fit at beta 1:

* with a stop check: `evaluate` inside `stopping.stop_when` with a check like the fit view's
  (a worker's `is_cancelled`, an attribute read), against the same evaluation outside it
  (where the check finds no function to ask): the median ratio of back-to-back pairs, in
  alternating order. Target: under 1.01x. (On a loaded machine this ratio is as noisy as the
  machine.)
* the checks alone: how many checks one evaluation makes, times one check's cost (timed in a
  loop of 100,000, as in `bench_maxent_stop`), as a share of the evaluation: what the checks cost against code without
  them, measured apart from the evaluation's noise.
* the longest stretch without a check: the largest gap between two checks (or between the
  start or end of `evaluate` and its nearest check), and where it falls: how late a stop can
  be heard.

Run: .venv/bin/python -m bench bench_evaluation_stop
"""

from __future__ import annotations

import time

import numpy as np

from bench.bench_maxent_stop import Worker, seconds_per_check, timed_in_pairs
from bench.fit_stage import demonstrations_for
from bench.worlds import cliff_world
from irl_core.irl import fit
from irl_core.irl.evaluation import evaluate
from irl_core.support.stopping import stop_when
from irl_core.worlds.mdp import build_mdp

PAIRS = 7


def main() -> None:
    mdp = build_mdp(cliff_world(64, 64))
    demos = demonstrations_for(mdp, episodes=20, seed=0)
    start = time.perf_counter()
    fitted = fit(demos, method="maxent", beta=1.0, reward_cells="special")
    print(f"cliff 64x64: the maxent fit (beta 1) took {time.perf_counter() - start:.1f} s")
    R_S = fitted.R_S
    worker = Worker()

    ratio, plain, checked = timed_in_pairs(lambda: evaluate(mdp, R_S), PAIRS, worker)

    asked: list[float] = []

    def timing() -> bool:
        asked.append(time.perf_counter())
        return worker.is_cancelled

    with stop_when(timing):
        began = time.perf_counter()
        evaluate(mdp, R_S)
        ended = time.perf_counter()
    moments = np.array([began, *asked, ended])
    gaps = np.diff(moments)
    longest = int(gaps.argmax())
    per_check = seconds_per_check(worker)
    evaluation_time = float(np.median(plain))
    print(f"one evaluation {evaluation_time * 1000:8.1f} ms (median of {len(plain)}), {len(asked)} checks")
    print(f"  with a stop check     {float(np.median(checked)) * 1000:8.1f} ms   {ratio:6.3f}x (median pair; "
          "target < 1.01x)")
    print(f"  the checks alone      {len(asked) * per_check * 1e6:8.1f} us   "
          f"{len(asked) * per_check / evaluation_time:8.5%} of the evaluation ({per_check * 1e9:.0f} ns a check)")
    print(f"  longest without a check {gaps[longest] * 1000:6.1f} ms, between moment {longest} and {longest + 1} "
          f"of {moments.size} (0: the start, {moments.size - 1}: the end); median gap {np.median(gaps) * 1000:.2f} ms")
    print("  the five longest gaps (ms, moment):",
          ", ".join(f"{gaps[i] * 1000:.1f} @ {i}" for i in np.argsort(gaps)[::-1][:5]))


if __name__ == "__main__":
    main()
