"""`careful study plan`: the default grid's time, and its predicted separation against full reports.

1. ``time``: the default grid (participants 5,10,20 x episodes 5,10,20, 20 studies each; players
   loose, timed, hasty, spread 0.3) on the README's study (one world, mud), on every core; the
   seconds go beside the target (600 s on this 2-core machine). A baseline in the same process, one
   participant's fit and Laplace interval, gives the ratio to compare across machines.
2. ``check``: at two grid points, the plan's predicted separation rate (with each of its pools) (the share of simulated
   studies whose pooled cliff interval lies below the mud's) against the rate measured by running
   the full `study report` pipeline (`gather`, `fit_report`: the auto model choice, bootstrap
   intervals, the report's pool) on N simulated studies whose participants are drawn as the plan
   draws them, written to disk as recordings. Target: within 15 points. With ``--fits report`` the plan
   fits its own simulated studies as the reports do (``study plan --fits report``: its N studies drawn with
   the plan's seeds, the reports' with their own), so the two differ only by their draws.

Run: .venv/bin/python -m bench bench_plan [--part time|check|predict|both] [--studies N] [--resamples R]
     [--calibration N] [--models NAME,...] [--point NxE] [--fits plan,report]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from irl_core.experiment.claims import order_words
from irl_core.irl.choices import POOL_MODELS
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.studies.forecast import write_simulated_study
from irl_core.studies.plan import PlanGrid, calibration_block, drawn_player, fit_participant, plan_study
from irl_core.studies.report import POOLED, fit_report, gather, report_options
from irl_core.studies.study import load_study
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

POINTS = ((5, 5), (5, 10))
TARGET_S = 600.0


def time_default_grid(workers: int) -> None:
    world = BUILTIN_WORLDS["mud"]
    mdp = build_mdp(world)
    unknowns = build_unknowns(mdp, tie=True)
    grid = PlanGrid()
    started = time.perf_counter()
    for seed in range(3):
        rng = np.random.default_rng(seed)
        played = rollouts(mdp, drawn_player(mdp, "loose", 0.3, rng).choose, episodes=10, rng=rng)
        fit_participant(mdp, unknowns, demonstrations_of(mdp, played).counts, grid)
    baseline = (time.perf_counter() - started) / 3
    started = time.perf_counter()
    points = plan_study((world,), grid, workers=workers)
    seconds = time.perf_counter() - started
    print(f"default grid on mud, {grid.repeats} studies per point, {workers} workers: {seconds:.0f} s "
          f"(target {TARGET_S:.0f} s); one participant's fit and interval (10 episodes): {baseline:.2f} s, "
          f"ratio {seconds / baseline:.0f}")
    for p in points:
        print(f"  {p.participants:>3} participants x {p.episodes:>3} episodes: separated {p.separated:.0%}, "
              f"covered {p.covered:.0%}, widths " + ", ".join(f"{s} {w:.0f}" for s, w in p.width.items()))


def write_study(folder: Path, participants: int, episodes: int, seed: int, grid: PlanGrid) -> Path:
    """A study of mud and `participants` drawn as the plan draws them, `episodes` main episodes each (after a
    calibration block of `grid.calibration` targets, in a file of its own, when there is one), written as the plan's
    ``--fits report`` writes its simulated studies (`write_simulated_study`)."""
    world = BUILTIN_WORLDS["mud"]
    mdp = build_mdp(world)
    played, trials = [], []
    for i in range(participants):
        rng = np.random.default_rng([seed, i, 7])
        player = drawn_player(mdp, grid.players[i % len(grid.players)], grid.spread, rng)
        played.append((player.player, rollouts(mdp, player.choose, episodes=episodes, rng=rng)))
        trials.append(calibration_block(player, world, grid.calibration, rng))  # after the episodes, as the plan
    return write_simulated_study(folder, world, played, trials, calibration=grid.calibration, seed=seed)


def reported_separation(participants: int, episodes: int, studies: int, resamples: int, workers: int, *,
                        calibration: int = 0) -> tuple[float, float]:
    """The share of `studies` full reports whose pooled cliff interval lies below the mud's, and the share whose
    every pooled interval holds the world's own reward."""
    grid = PlanGrid(calibration=calibration)
    separated, covered = [], []
    for s in range(studies):
        with tempfile.TemporaryDirectory() as folder:
            data = gather(load_study(write_study(Path(folder), participants, episodes, 1000 + s, grid)))
            fits = fit_report(data, report_options(resamples=resamples, seed=s), workers=workers)
        pooled = next(f for c, f in zip(data.cells, fits) if c.participant == POOLED)
        if pooled.intervals is None:
            separated.append(False)
            covered.append(False)
            continue
        cliff, mud = pooled.symbols.index("C"), pooled.symbols.index("U")
        separated.append(order_words(tuple(pooled.intervals[cliff]), tuple(pooled.intervals[mud])) == "below")
        rewards = BUILTIN_WORLDS["mud"].rewards
        covered.append(all(low <= rewards[symbol] <= high for symbol, (low, high) in zip(pooled.symbols, pooled.intervals)))
        print(f"    study {s}: pooled cliff {pooled.intervals[cliff].round(0).tolist()}, mud "
              f"{pooled.intervals[mud].round(1).tolist()} ({pooled.player_model}): "
              f"{'separated' if separated[-1] else 'not separated'}, "
              f"{'every interval holds the truth' if covered[-1] else 'not covered'}", flush=True)
    return float(np.mean(separated)), float(np.mean(covered))


def check(studies: int, resamples: int, workers: int, *, measure: bool = True, calibration: int = 0,
          models: tuple[str, ...] = ("person",), points: tuple[tuple[int, int], ...] = POINTS,
          fits: tuple[str, ...] = ("plan",)) -> None:
    world = BUILTIN_WORLDS["mud"]
    for n, e in points:
        if "plan" in fits:
            for model in models:
                for pool in POOL_MODELS:
                    grid = PlanGrid(participants=(n,), episodes=(e,), pool=pool, calibration=calibration, model=model)
                    predicted = plan_study((world,), grid, workers=workers)[0]
                    print(f"{n} participants x {e} episodes, calibration {calibration}: the plan ({model} model, {pool} "
                          f"pool) predicts separation in {predicted.separated:.0%}, coverage {predicted.covered:.0%} "
                          f"({grid.repeats} simulated studies)", flush=True)
        if "report" in fits:
            grid = PlanGrid(participants=(n,), episodes=(e,), calibration=calibration, fits="report",
                            resamples=resamples, repeats=studies)
            started = time.perf_counter()
            predicted = plan_study((world,), grid, workers=workers)[0]
            print(f"{n} participants x {e} episodes, calibration {calibration}: the plan (--fits report, "
                  f"{resamples} resamples) predicts separation in {predicted.separated:.0%}, coverage "
                  f"{predicted.covered:.0%} ({grid.repeats} simulated studies, {time.perf_counter() - started:.0f} s)",
                  flush=True)
        if not measure:
            continue
        measured, held = reported_separation(n, e, studies, resamples, workers, calibration=calibration)
        print(f"{n} participants x {e} episodes: measured by {studies} full reports (--resamples {resamples}): "
              f"separation {measured:.0%} (target: a prediction within 15 points), coverage {held:.0%}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--part", choices=("time", "check", "predict", "both"), default="both",
                        help="predict: the check's predictions only, without the full reports")
    parser.add_argument("--studies", type=int, default=20)
    parser.add_argument("--resamples", type=int, default=200)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--calibration", type=int, default=0, metavar="N",
                        help="the check's participants first hold N calibration targets (default 0: none)")
    parser.add_argument("--models", default="person", metavar="NAME,...",
                        help="the plan's player models to predict with (default person)")
    parser.add_argument("--point", default=None, metavar="NxE", help="one grid point instead of 5x5 and 5x10")
    parser.add_argument("--fits", default="plan", metavar="NAME,...",
                        help="the plan's fits to predict with: plan, report or both (default plan)")
    args = parser.parse_args()
    points: tuple[tuple[int, int], ...] = POINTS
    if args.point is not None:
        n, e = (int(v) for v in args.point.split("x"))
        points = ((n, e),)
    if args.part in ("time", "both"):
        time_default_grid(args.workers)
    if args.part in ("check", "predict", "both"):
        check(args.studies, args.resamples, args.workers, measure=args.part != "predict", calibration=args.calibration,
              models=tuple(args.models.split(",")), points=points, fits=tuple(args.fits.split(",")))


if __name__ == "__main__":
    main()
