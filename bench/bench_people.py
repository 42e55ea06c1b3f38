"""Person-like play: does the default fit for noisy play get people's rewards right?

For each person-like player (irl_core.players.person_like) and world (`mud`, `walls`), N seeds of 30
episodes, each fitted as a user's recordings are by default: `FitOptions(method="auto",
intervals=True, resamples=200, seed=seed)` (per-cell unknowns; `--tie` for one per symbol, as
people's data are usually fitted). Per (player, world) it reports, as a Markdown table:

* order: the share of runs with hazard < nuisance < 0 < goal (C < U < 0 < G), read from each
  symbol's value: the tied unknown with `--tie`, else the median over the symbol's cells;
* covered C/U/G: the share of the symbol's 95% intervals that contain the truth, over runs and
  the symbol's cells (a run without intervals covers nothing);
* cliff <= 1%: the share of runs in which an agent trained on the fit falls off the cliff in at
  most 1% of episodes (`evaluation`, exact, from the world's start distribution);
* fit check: the share of runs whose fit check passed, once fits have one;
* the median of each symbol's value over runs, the methods (and player models) the fits used,
  and the median seconds per fit.

The fits run in a process pool over runs (each fit's bootstrap on one process). Targets for a
fit meant for people (docs/people.md): order and cliff in at least 90% of runs, every symbol
covered in at least 75%, for `loose`, `timed` and `hasty`; the fit check fails on `inverted`.
`table(...)` takes any options, so another player model can be measured the same way.

With ``--calibration N`` each player first does a study's motor calibration block of N targets
(`person_like.motor_trials`), and the fit holds the hand those trials measure.

Run: .venv/bin/python -m bench bench_people [--seeds N] [--quick] [--tie] [--players ...] [--worlds ...]
     [--calibration N] [--option NAME=VALUE ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from collections import Counter
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

import numpy as np

from bench.option_values import name_and_value
from irl_core.errors import FitError
from irl_core.irl import FitOptions, fit
from irl_core.play.motor_block import calibration_targets
from irl_core.players.experts import demonstrations_of, rollouts
from irl_core.players.person_like import LEVEL_KINDS, motor_trials, person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

EPISODES = 30
WORLDS = ("mud", "walls")
PLAYERS = LEVEL_KINDS
SYMBOLS = ("C", "U", "G")  # hazard, nuisance, goal
CLIFF_RATE = 0.01


def default_options(seed: int, *, tie: bool = False) -> FitOptions:
    """The library's default fit for noisy play, with intervals, as a user runs it."""
    return FitOptions(method="auto", intervals=True, resamples=200, seed=seed, tie=tie)


@dataclass(frozen=True)
class Run:
    """One fit's outcome: each symbol's value (tied, or the median of its cells) and the share of its
    cells whose interval holds the truth, the agent's cliff rate, the fit check (None without one),
    the method (and player model, once fits name one) that was used."""

    player: str
    world: str
    seed: int
    value: dict[str, float]
    covered: dict[str, float]
    cliff: float
    fit_check: bool | None
    seconds: float
    model: str = ""
    error: str | None = None

    @property
    def ordered(self) -> bool:
        v = self.value
        return self.error is None and v["C"] < v["U"] < 0 < v["G"]


def one_run(player: str, world: str, seed: int, options: FitOptions, episodes: int = EPISODES,
            calibration: int = 0) -> Run:
    """Roll out `episodes` of `player` in `world` with `seed` and fit them with `options` on one process;
    with `calibration` targets, the player first does a study's motor calibration block of that many."""
    mdp = build_mdp(BUILTIN_WORLDS[world])
    stream = np.random.SeedSequence([seed, PLAYERS.index(player), WORLDS.index(world) if world in WORLDS else 9])
    rng = np.random.default_rng(stream)
    person = person_like(mdp, player)
    demos = demonstrations_of(mdp, rollouts(mdp, person.choose, episodes=episodes, rng=rng))
    if calibration:
        targets = np.array(calibration_targets(mdp.levels, calibration, seed=seed))
        demos = dataclasses.replace(demos, calibration=motor_trials(person, targets, mdp.levels, rng))
    started = time.perf_counter()
    try:
        result = fit(demos, options, workers=1)
    except FitError as exc:
        nan = dict.fromkeys(SYMBOLS, float("nan"))
        return Run(player, world, seed, nan, dict.fromkeys(SYMBOLS, 0.0), float("nan"), None,
                   time.perf_counter() - started, error=str(exc))
    truth = result.unknowns.true_theta(mdp)
    symbols = np.array(result.unknowns.symbols)
    value, covered = {}, {}
    for symbol in SYMBOLS:
        mine = symbols == symbol
        value[symbol] = float(np.median(result.theta[mine]))
        if result.intervals is None:
            covered[symbol] = 0.0
        else:
            low, high = result.intervals[mine].T
            covered[symbol] = float(np.mean((low <= truth[mine]) & (truth[mine] <= high)))
    check = getattr(result, "fit_check", None)
    passed = None if check is None else bool(check["passed"] if isinstance(check, dict) else check.passed)
    model = getattr(result, "player_model", None) or getattr(result.options, "player_model", None)
    return Run(player, world, seed, value, covered, float(result.evaluation.agent.ends.get("C", 0.0)), passed,
               time.perf_counter() - started, model=result.method + (f" {model}" if model else ""))


def runs(players: Iterable[str], worlds: Iterable[str], seeds: Iterable[int], *,
         options: Callable[[int], FitOptions] = default_options, workers: int | None = None,
         progress: Callable[[int, int, Run], None] | None = None, calibration: int = 0) -> list[Run]:
    """Every (player, world, seed) fitted with `options(seed)`, `workers` fits at a time (default: the cores),
    each player doing a motor calibration block of `calibration` targets first (0: none)."""
    jobs = [(p, w, s, options(s)) for p in players for w in worlds for s in seeds]
    done: list[Run] = []
    with ProcessPoolExecutor(max_workers=workers or os.cpu_count()) as pool:
        futures = [pool.submit(one_run, *job, EPISODES, calibration) for job in jobs]
        for future in as_completed(futures):
            done.append(future.result())
            if progress is not None:
                progress(len(done), len(jobs), done[-1])
    order = {job[:3]: i for i, job in enumerate(jobs)}
    return sorted(done, key=lambda run: order[run.player, run.world, run.seed])


def table(done: list[Run]) -> str:
    """The Markdown table of `done`, a row per (player, world) in the order they first appear."""
    head = ("| player | world | runs | order | covered C | covered U | covered G | cliff <= 1% | fit check "
            "| median C | median U | median G | fitted by | s per fit |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    groups: dict[tuple[str, str], list[Run]] = {}
    for run in done:
        groups.setdefault((run.player, run.world), []).append(run)
    for (player, world), group in groups.items():
        n = len(group)
        ok = [run for run in group if run.error is None]
        checks = [run.fit_check for run in ok if run.fit_check is not None]
        cells = [
            player, world, str(n),
            f"{sum(run.ordered for run in group)}/{n}",
            *(f"{np.mean([run.covered[s] for run in group]):.0%}" for s in SYMBOLS),
            f"{sum(run.cliff <= CLIFF_RATE for run in ok)}/{n}",
            f"{sum(checks)}/{len(checks)}" if checks else "n/a",
            *(f"{np.median([run.value[s] for run in ok]):.4g}" if ok else "n/a" for s in SYMBOLS),
            ", ".join(f"{model} {count}" for model, count in Counter(run.model for run in ok).most_common()) or "n/a",
            f"{np.median([run.seconds for run in group]):.1f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _option(text: str) -> tuple[str, object]:
    """``NAME=VALUE`` as a FitOptions field and its value: a number, true/false, or text."""
    name, value = name_and_value(text)
    if name not in {f.name for f in dataclasses.fields(FitOptions)}:
        raise argparse.ArgumentTypeError(f"FitOptions has no field {name!r}")
    return name, value


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_people", description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds per player and world (default 10)")
    parser.add_argument("--quick", action="store_true", help="a 2-seed slice")
    parser.add_argument("--tie", action="store_true", help="one unknown per symbol")
    parser.add_argument("--players", nargs="+", choices=PLAYERS, default=list(PLAYERS))
    parser.add_argument("--worlds", nargs="+", choices=list(BUILTIN_WORLDS), default=list(WORLDS))
    parser.add_argument("--calibration", type=int, default=0, metavar="N",
                        help="each player does a motor calibration block of N targets first (default 0: none)")
    parser.add_argument("--workers", type=int, default=None, help="fits at a time (default: the cores)")
    parser.add_argument("--option", action="append", default=[], metavar="NAME=VALUE", type=_option,
                        help="a FitOptions field to set in every fit, e.g. --option rmax=5000 (repeatable)")
    args = parser.parse_args()
    changes = dict(args.option)
    seeds = range(2 if args.quick else args.seeds)
    started = time.perf_counter()

    def report(done: int, total: int, run: Run) -> None:
        what = run.error or ("  ".join(f"{s} {run.value[s]:.4g}" for s in SYMBOLS) + f"  cliff {run.cliff:.2%}")
        print(f"[{done:3d}/{total}] {run.player:<9} {run.world:<6} seed {run.seed:2d}: {what}  ({run.seconds:.1f} s)",
              flush=True)

    done = runs(args.players, args.worlds, seeds,
                options=lambda seed: dataclasses.replace(default_options(seed, tie=args.tie), **changes),
                workers=args.workers, progress=report, calibration=args.calibration)
    unknowns = "one per symbol (--tie)" if args.tie else "one per cell, each symbol read as its cells' median"
    changed = "".join(f", {name} {value}" for name, value in changes.items())
    changed += f", a calibration block of {args.calibration} targets" if args.calibration else ""
    print(f"\n{EPISODES} episodes per run, {len(seeds)} seeds, the default fit with 200 resamples{changed}; unknowns "
          f"{unknowns}; {time.perf_counter() - started:.0f} s on {args.workers or os.cpu_count()} workers\n")
    print(table(done))


if __name__ == "__main__":
    main()
