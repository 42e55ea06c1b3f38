"""Coverage on a battery of players the fit's models do not contain (docs/battery.md; issue 46, item 4).

For each player of the battery and each seed, one recording of the issue's probes' size is simulated and fitted
as a user fits it, once per ``--fit-args``; each reward's 95% interval is checked against the truth, counted as
`careful check` counts (`irl_core.coverage.check.tally`: the world's rewards in the fit's unit; per cell, a
symbol is covered when every one of its cells' intervals holds its truth).

* worlds with levels (`mud`, `paper`): 30 episodes of ``loose``, ``timed``, ``hasty``, ``streaky``, ``growing``,
  ``learning``, from the world's starts;
* the time world (`mud-time`): as bench_timing plays it, 30 players of the kind (``timing``, whose holds scatter
  log-normally around the best hold, and ``steady``), each with their own parameters drawn around the defaults,
  20 episodes each, pooled into one recording;
* ``--part population``: the study's population row, a small study per seed (``--participants`` of one kind, 10
  episodes each on `mud`, through `study report`'s fits and pool), its pooled interval against the truth.

The fit options are `careful fit`'s own flags, one string per fit (``--fit-args``, repeatable; default the two
fits a user runs, ``--tie --intervals`` and ``--intervals``). Intervals are always on, and each seed's fit is
seeded with that seed. So another kind of interval is measured the same way by naming its flag:

    python -m bench bench_battery --fit-args "--tie --intervals --widen calibrated"

Each run prints a line as it finishes; the table last (player, world, fit, symbol, covered/seeds, median width,
median error, the point's sd over seeds, the methods and player models the fits chose), as Markdown. Rows
below 80% are the ones docs/battery.md explains.

    nice -n 15 .venv/bin/python -m bench bench_battery --seeds 20                       # the whole battery
    nice -n 15 .venv/bin/python -m bench bench_battery --part population --seeds 20     # the study's row
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shlex
import tempfile
import time
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.bench_timing import pooled_players
from careful_tui.arguments import add_fit_options, options_from_args
from careful_tui.option_words import said
from irl_core.coverage.check import CoverageRow, DatasetFit, tally
from irl_core.errors import FitError
from irl_core.irl import FitOptions, fit
from irl_core.players.experts import demonstrations_of, rollouts, session_header, write_rollouts
from irl_core.players.person_like import person_like
from irl_core.recordings.lines import StudyTag
from irl_core.studies.report import POOLED, fit_report, gather
from irl_core.studies.study import load_study
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World

EPISODES = 30
LEVEL_WORLDS = ("mud", "paper")
LEVEL_PLAYERS = ("loose", "timed", "hasty", "streaky", "growing", "learning")
TIME_WORLD = "mud-time"
TIME_PLAYERS = ("timing", "steady")
DEFAULT_FITS = ("--tie --intervals", "--intervals")
POPULATION_KINDS = ("loose", "streaky")
TARGET = 0.8


def fit_options(text: str) -> FitOptions:
    """`careful fit`'s flags in `text` as its FitOptions, intervals on (a bad flag: argparse's error, exit 2)."""
    parser = argparse.ArgumentParser(prog="--fit-args", allow_abbrev=False, add_help=False)
    add_fit_options(parser)
    options = options_from_args(parser.parse_args(shlex.split(text)))
    problem = options.problem()
    if problem:
        parser.error(said(problem))
    return dataclasses.replace(options, intervals=True)


@dataclass(frozen=True)
class Run:
    """One recording's fit: the player, world, fit flags and seed, its unknowns' symbols and truth, the fit."""

    player: str
    world: str
    fit_args: str
    seed: int
    symbols: tuple[str, ...]
    truth: np.ndarray
    fitted: DatasetFit
    model: str
    seconds: float


def recording(player: str, world: str, seed: int):
    """The demonstrations of one seed: 30 episodes on a world with levels; bench_timing's 30 x 20 on a time world."""
    mdp = build_mdp(BUILTIN_WORLDS[world])
    if world == TIME_WORLD:
        return pooled_players(mdp, player, seed=seed)
    stream = np.random.SeedSequence([seed, LEVEL_PLAYERS.index(player), LEVEL_WORLDS.index(world)])
    return demonstrations_of(mdp, rollouts(mdp, person_like(mdp, player).choose, episodes=EPISODES,
                                           rng=np.random.default_rng(stream)))


def one_run(player: str, world: str, fit_args: str, seed: int) -> Run:
    demos = recording(player, world, seed)
    options = dataclasses.replace(fit_options(fit_args), seed=seed)
    started = time.perf_counter()
    try:
        result = fit(demos, options, workers=1)
    except FitError as exc:
        nothing = DatasetFit(None, None, f"the fit failed ({getattr(exc, 'code', None) or type(exc).__name__})")
        return Run(player, world, fit_args, seed, (), np.zeros(0), nothing, "", time.perf_counter() - started)
    intervals = None if result.intervals is None else np.asarray(result.intervals, dtype=float)
    fitted = DatasetFit(np.asarray(result.theta, dtype=float), intervals, None if intervals is not None else "no intervals")
    model = result.method + (f" {result.player_model}" if result.player_model else "")
    return Run(player, world, fit_args, seed, tuple(result.unknowns.symbols), np.asarray(result.true_theta(), dtype=float),
               fitted, model, time.perf_counter() - started)


def coverage_rows(done: list[Run], rmax_of: dict[str, float]) -> list[tuple[str, str, str, CoverageRow, int]]:
    """(player, world, fit args, the symbol's coverage row, seeds) per group and symbol, in the order of `done`."""
    groups: dict[tuple[str, str, str], list[Run]] = {}
    for run in done:
        groups.setdefault((run.player, run.world, run.fit_args), []).append(run)
    rows = []
    for (player, world, fit_args), runs in groups.items():
        fitted = [run for run in runs if run.symbols]
        if not fitted:
            continue
        # Every fit of one world and one set of flags has the same unknowns; the truth is the world's.
        for row in tally(player, rival=True, symbols=fitted[0].symbols, truth=fitted[0].truth,
                         fits=[run.fitted for run in fitted], rmax=rmax_of[fit_args]):
            rows.append((player, world, fit_args, row, len(runs)))
    return rows


def point_sd(done: list[Run], group: tuple[str, str, str], symbol: str) -> float:
    """The sd over seeds of the symbol's point (its cells' median, per cell): set beside the median width, it
    tells intervals too narrow for the seed-to-seed spread (width well under 3.9 sd) from a point that is biased
    (width about 3.9 sd, the truth outside anyway)."""
    points = [float(np.median(run.fitted.theta[[s == symbol for s in run.symbols]]))
              for run in done if (run.player, run.world, run.fit_args) == group and run.fitted.theta is not None]
    return float(np.std(points, ddof=1)) if len(points) > 1 else float("nan")


def table(done: list[Run], rmax_of: dict[str, float]) -> str:
    head = "| player | world | fit | symbol | covered | median width | median error | point sd | fitted by |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    models: dict[tuple[str, str, str], dict[str, int]] = {}
    for run in done:
        counted = models.setdefault((run.player, run.world, run.fit_args), {})
        counted[run.model or "failed"] = counted.get(run.model or "failed", 0) + 1
    for player, world, fit_args, row, seeds in coverage_rows(done, rmax_of):
        mark = " **<80%**" if row.covered < TARGET * seeds else ""
        by = ", ".join(f"{m} {n}" for m, n in sorted(models[player, world, fit_args].items(), key=lambda x: -x[1]))
        lines.append(f"| {player} | {world} | `{fit_args}` | {row.symbol} | {row.covered}/{seeds}{mark} | "
                     f"{row.median_width:.4g} | {row.median_error:+.4g} | "
                     f"{point_sd(done, (player, world, fit_args), row.symbol):.4g} | {by} |")
    return "\n".join(lines)


def battery(jobs: Iterable[tuple[str, str, str, int]], workers: int) -> list[Run]:
    """Every job's run, `workers` at a time. Ctrl+C stops it and keeps the runs done (the table then counts
    the seeds each row has; jobs go seed by seed, so a stopped run has about as many seeds in every row)."""
    jobs = list(jobs)
    done: list[Run] = []
    pool = ProcessPoolExecutor(max_workers=workers)
    try:
        futures = [pool.submit(one_run, *job) for job in jobs]
        for future in as_completed(futures):
            run = future.result()
            done.append(run)
            what = run.fitted.problem or "  ".join(
                f"{s} {v:.4g} [{lo:.4g}, {hi:.4g}]" for s, v, (lo, hi) in
                zip(run.symbols, run.fitted.theta, run.fitted.intervals))  # type: ignore[arg-type]
            print(f"[{len(done):3d}/{len(jobs)}] {run.player:<8} {run.world:<8} {run.fit_args!r:<20} seed {run.seed:2d}: "
                  f"{what}  {run.model}  ({run.seconds:.1f} s)", flush=True)
    except KeyboardInterrupt:
        print(f"stopped: {len(done)} of {len(jobs)} runs done", flush=True)
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    order = {job: i for i, job in enumerate(jobs)}
    return sorted(done, key=lambda run: order[run.player, run.world, run.fit_args, run.seed])


def population_study(kind: str, seed: int, *, participants: int, resamples: int, folder: Path) -> dict:
    """One study of `participants` players of `kind`, 10 episodes each on mud, through the report's fits and its
    population pool: whether the pooled row's interval holds each truth."""
    path = folder / f"{kind}-{seed}" / "study.toml"
    path.parent.mkdir(parents=True)
    path.write_text('name = "battery"\nworlds = ["mud"]\npractice_episodes = 0\nepisodes = 10\nout = "data"\n')
    study = load_study(path)
    world = study.worlds[0]
    assert isinstance(world, World)  # mud, a grid world (a study's worlds may also be reach worlds)
    mdp = build_mdp(world)
    player = person_like(mdp, kind)
    for i in range(participants):
        who = f"p{i + 1:02d}"
        (study.participant_folder(who)).mkdir(parents=True)
        tag = StudyTag(name="battery", participant=who, phase="main", world_index=0)
        header = session_header(mdp, player=player.player, seed=seed * 100 + i).model_copy(
            update={"player": who, "study": tag})
        played = rollouts(mdp, player.choose, episodes=10, seed=seed * 100 + i)
        write_rollouts(study.participant_folder(who) / f"{who}-0-w0-main.jsonl", mdp, played, player=player.player,
                       seed=seed * 100 + i, header=header)
    data = gather(study)
    fits = fit_report(data, FitOptions(method="auto", tie=True, intervals=True, resamples=resamples, seed=seed,
                                       rmax=5000.0), workers=2)
    pooled = dict(zip((c.participant for c in data.cells), fits))[POOLED]
    assert pooled.intervals is not None
    truth = dict(zip(pooled.symbols, pooled.truth))
    return {s: (bool(lo <= truth[s] <= hi), float(hi - lo)) for s, (lo, hi) in zip(pooled.symbols, pooled.intervals)}


def population(kinds: tuple[str, ...], seeds: range, *, participants: int, resamples: int) -> str:
    head = "| player | world | pool | symbol | covered | median width |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    with tempfile.TemporaryDirectory() as folder:
        for kind in kinds:
            held: dict[str, list[tuple[bool, float]]] = {}
            for seed in seeds:
                row = population_study(kind, seed, participants=participants, resamples=resamples, folder=Path(folder))
                print(f"{kind} seed {seed}: " + "  ".join(f"{s} {'held' if ok else 'MISSED'} (width {w:.4g})"
                                                         for s, (ok, w) in row.items()), flush=True)
                for symbol, value in row.items():
                    held.setdefault(symbol, []).append(value)
            for symbol, values in held.items():
                covered = sum(ok for ok, _ in values)
                mark = " **<80%**" if covered < TARGET * len(values) else ""
                lines.append(f"| {kind} | mud | {participants} x 10, population | {symbol} | {covered}/{len(values)}{mark} "
                             f"| {np.median([w for _, w in values]):.4g} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="python -m bench bench_battery", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--part", choices=("fits", "population"), default="fits")
    parser.add_argument("--seeds", type=int, default=20, help="seeds per player, world and fit (default 20)")
    parser.add_argument("--players", nargs="+", default=[*LEVEL_PLAYERS, *TIME_PLAYERS],
                        choices=[*LEVEL_PLAYERS, *TIME_PLAYERS], help="the players (default all)")
    parser.add_argument("--worlds", nargs="+", default=[*LEVEL_WORLDS, TIME_WORLD], choices=[*LEVEL_WORLDS, TIME_WORLD],
                        help="the worlds (default mud, paper, mud-time; the time world's players are timing, steady)")
    parser.add_argument("--fit-args", action="append", default=None, metavar="FLAGS",
                        help="careful fit's flags for one fit, as one string (repeatable; default "
                             + " and ".join(repr(f) for f in DEFAULT_FITS) + "); --intervals is always on and --seed "
                             "is each run's seed")
    parser.add_argument("--workers", type=int, default=2, help="fits at a time (default 2)")
    parser.add_argument("--population-kinds", nargs="+", default=list(POPULATION_KINDS), choices=LEVEL_PLAYERS)
    parser.add_argument("--participants", type=int, default=8, help="participants per population study (default 8)")
    parser.add_argument("--resamples", type=int, default=100, help="resamples of a population study's fits (default 100)")
    args = parser.parse_args()
    started = time.perf_counter()
    seeds = range(args.seeds)
    if args.part == "population":
        print(population(tuple(args.population_kinds), seeds, participants=args.participants, resamples=args.resamples))
        print(f"\n{time.perf_counter() - started:.0f} s")
        return
    fits = args.fit_args or list(DEFAULT_FITS)
    rmax_of = {text: fit_options(text).rmax for text in fits}  # a bad flag stops here, before any fit
    jobs = [(player, world, text, seed) for seed in seeds for world in args.worlds for player in args.players
            if (player in TIME_PLAYERS) == (world == TIME_WORLD) for text in fits]
    done = battery(jobs, args.workers)
    print(f"\n{len(done)} fits, up to {args.seeds} seeds each, {time.perf_counter() - started:.0f} s on {args.workers} "
          f"workers (load {os.getloadavg()[0]:.1f})\n")
    print(table(done, rmax_of))


if __name__ == "__main__":
    main()
