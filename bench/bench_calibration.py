"""How often the bootstrap's 95% intervals contain the truth (coverage), for noisy experts.

20 seeds, each 40 Boltzmann episodes (beta 0.5) on `mud`; maxent with beta estimated,
tied (one unknown per symbol), rmax 5000 (so that an interval running to -rmax is no free
win for the cliff at -1000), 200 resamples of whole episodes. For every seed and unknown it
records whether the percentile and the basic interval contain the true reward, and prints
the counts out of 20. Target: cliff and mud covered in at least 17 of 20.

This is a study, not a timing: it took 21 s on a 2-core machine at load 2.

Run: .venv/bin/python -m bench bench_calibration [--seeds N]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from irl_core.irl import FitOptions, fit
from irl_core.irl.intervals.bootstrap import VARIANTS, Refit, bootstrap, interval
from irl_core.irl.maxent import curvature_scale
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

BETA, EPISODES, RMAX, RESAMPLES, CONFIDENCE = 0.5, 40, 5000.0, 200, 0.95


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_calibration")
    parser.add_argument("--seeds", type=int, default=20)
    seeds = parser.parse_args().seeds
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    policy = boltzmann_policy(mdp, beta=BETA)
    options = FitOptions(method="maxent", beta="auto", tie=True, rmax=RMAX)
    covered = {variant: np.zeros(0, dtype=int) for variant in VARIANTS}
    widths = []
    started = time.perf_counter()
    for seed in range(seeds):
        demos = demonstrations_of(mdp, rollouts(mdp, policy, episodes=EPISODES, seed=1000 + seed))
        result = fit(demos, options)
        beta = result.beta
        assert beta is not None, "a maxent fit with beta auto reports its estimate"
        truth = np.append(result.unknowns.true_theta(mdp), BETA)
        scale = curvature_scale(mdp, result.unknowns, demos.counts, theta=result.theta, beta=beta,
                                estimate=True, rmax=RMAX)
        refit = Refit(mdp=mdp, unknowns=result.unknowns, method="maxent", rmax=RMAX, lam=0.0, beta="auto",
                      start=(result.theta, beta), scale=scale, start_V=result.V)
        full = np.append(result.theta, beta)
        boot = bootstrap(refit, demos.by_episode, full, confidence=CONFIDENCE, resamples=RESAMPLES, seed=seed)
        ok = ~np.isnan(boot.estimates).any(axis=1)
        for variant in VARIANTS:
            bounds = interval(boot.estimates[ok], full, confidence=CONFIDENCE, variant=variant)
            bounds[:-1] = np.clip(bounds[:-1], -RMAX, RMAX)
            hit = (bounds[:, 0] <= truth) & (truth <= bounds[:, 1])
            covered[variant] = hit.astype(int) if seed == 0 else covered[variant] + hit
        widths.append(boot.intervals[:, 1] - boot.intervals[:, 0])
        print(f"seed {seed:2d}: estimate {np.round(full, 3)}  percentile {np.round(boot.intervals, 1).tolist()}",
              flush=True)
    labels = [*result.unknowns.labels, "beta"]
    print(f"\ncoverage of the true value by the {CONFIDENCE:.0%} intervals, out of {seeds} seeds "
          f"({EPISODES} episodes each, {RESAMPLES} resamples; {time.perf_counter() - started:.0f} s):")
    for variant in VARIANTS:
        print(f"  {variant:<10} " + "  ".join(f"{label} {n}/{seeds}" for label, n in zip(labels, covered[variant])))
    print("  median width (percentile): "
          + "  ".join(f"{label} {w:.3g}" for label, w in zip(labels, np.median(widths, axis=0))))


if __name__ == "__main__":
    main()
