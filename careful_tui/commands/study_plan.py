"""`careful study plan STUDY.toml`: simulate whole studies before running one (docs/studies.md#planning-a-study).

The computation is `irl_core.studies.plan`; this module parses the grid and the hypothesised
rewards, shows a progress bar on stderr, prints the table on stdout and writes ``plan.csv`` and the
figure (PDF and PNG) under ``<out>/plan/`` through the output guard (a file is written beside its
final name and renamed, so Ctrl+C never leaves a partial one there).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from rich import box
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from careful_tui.errors import EXIT_OK
from careful_tui.render.grid import SYMBOL_NAMES
from irl_core.errors import PlanError, StudyError, UsageError
from irl_core.studies.plan import TIME_WORLDS_NOT_PLANNED, PlanGrid, PlanPoint, plan_study, planned_worlds, without_time_worlds
from irl_core.studies.study import PLAN_FOLDER, load_study, world_files
from irl_core.support.csv_cells import csv_text, text_cell
from irl_core.support.safe_files import check_output_folder, write_output
from irl_core.support.safe_text import printable

FIGURE_FORMATS = (".png", ".pdf")


def parse_sizes(text: str, *, option: str) -> tuple[int, ...]:
    """"5,10,20" -> (5, 10, 20); raises UsageError naming `option` for anything else."""
    try:
        return tuple(int(part) for part in text.split(","))
    except ValueError:
        raise UsageError(f"{option}: give whole numbers separated by commas, e.g. 5,10,20, "
                         f"not {printable(text, limit=40)!r}") from None


def parse_truth(text: str) -> dict[str, float]:
    """"C=-1000,U=-30,G=100" -> {"C": -1000.0, ...}; raises UsageError naming --truth for anything else."""
    truth: dict[str, float] = {}
    for part in text.split(","):
        symbol, equals, value = part.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not equals or len(symbol.strip()) != 1 or not abs(number) < float("inf"):
            raise UsageError(f"--truth: give SYMBOL=REWARD pairs separated by commas, e.g. C=-1000,U=-30,G=100, "
                             f"not {printable(part, limit=40)!r}")
        truth[symbol.strip()] = number
    return truth


def run_study_plan(args: argparse.Namespace) -> int:
    try:
        study = load_study(args.study)
    except StudyError as exc:
        raise UsageError(str(exc)) from None
    try:
        grid = PlanGrid(participants=parse_sizes(args.participants, option="--participants"),
                        episodes=parse_sizes(args.episodes, option="--episodes"),
                        players=tuple(p.strip() for p in args.players.split(",")), repeats=args.repeats,
                        spread=args.spread, seed=args.seed, pool=args.pool_model, model=args.player_model,
                        fits=args.fits, resamples=args.resamples, exclusions=study.study.exclusions,
                        calibration=study.study.calibration_block if args.calibration is None else args.calibration)
        worlds = planned_worlds(study.grid_worlds, parse_truth(args.truth) if args.truth else {}, rmax=grid.rmax)
    except PlanError as exc:
        raise UsageError(f"--{exc.field}: {exc.reason}") from None
    worlds, left_out = without_time_worlds(worlds)
    if not worlds:
        raise UsageError(f"{printable(str(study.path), limit=160)}: every world of the study is a time world, "
                         f"and {TIME_WORLDS_NOT_PLANNED}")
    out = check_output_folder((args.out if args.out is not None else study.out) / PLAN_FOLDER, option="--out")
    err = Console(stderr=True, highlight=False)
    started = time.perf_counter()
    workers = args.workers or os.cpu_count() or 1
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=err, transient=True) as progress:
        task = progress.add_task(f"simulating {grid.repeats} studies per world and grid point", total=None)
        points = plan_study(worlds, grid, workers=workers,
                            progress=lambda done, total: progress.update(task, completed=done, total=total))
        progress.update(task, description="drawing the figure", completed=0, total=None)
        try:
            written = write_plan(points, worlds, out, inputs=[study.path, *world_files(study)])
        except OSError as exc:
            raise UsageError(f"--out {printable(str(out), limit=160)}: cannot write there "
                             f"({exc.strerror or exc})") from None
    out_console = Console(highlight=False)
    if not out_console.is_terminal:
        out_console.width = 160
    out_console.print(plan_table(points, grid))
    for line in plan_findings(points, confidence=grid.confidence, fits=grid.fits):
        out_console.print(Text(line), soft_wrap=True)
    for world in left_out:
        line = f"{printable(world.name, limit=30)}: a time world, left out ({TIME_WORLDS_NOT_PLANNED})."
        out_console.print(Text(line), soft_wrap=True)
    err.print(Text(f"wrote {len(written)} files to {printable(str(out), limit=160)} (plan.csv and the figure) in "
                   f"{time.perf_counter() - started:.0f} s"), soft_wrap=True)
    return EXIT_OK


def plan_rows(points: list[PlanPoint]) -> tuple[list[str], list[list[str]]]:
    """plan.csv: world, participants, episodes, studies, calibration (targets per participant), separated,
    covered, then per symbol (hazard first)
    its hypothesised reward (``truth_X``), the share of pooled intervals holding it (``covered_X``) and
    their median width (``width_X``). Shares are fractions; ``separated`` is empty without a nuisance."""
    symbols = sorted({s for p in points for s in p.symbols},
                     key=lambda s: min(t for p in points for q, t in zip(p.symbols, p.truth) if q == s))
    columns = ["world", "participants", "episodes", "studies", "calibration", "separated", "covered",
               *(f"{kind}_{s}" for s in symbols for kind in ("truth", "covered", "width"))]
    rows = []
    for p in points:
        truth = dict(zip(p.symbols, p.truth))
        cells = []
        for s in symbols:
            cells += ([f"{truth[s]:g}", f"{p.covered_each[s]:.4g}", f"{p.width[s]:.6g}"] if s in truth else ["", "", ""])
        rows.append([text_cell(p.world), str(p.participants), str(p.episodes), str(p.studies), str(p.calibration),
                     "" if p.separated is None else f"{p.separated:.4g}", f"{p.covered:.4g}", *cells])
    return columns, rows


def write_plan(points: list[PlanPoint], worlds, out: Path, *, inputs: list[Path]) -> list[Path]:
    """plan.csv and the figure in `out` (through the output guard); returns the files written."""
    from careful_tui.render.figures.plan_figure import plan_figure
    from careful_tui.render.figures.style import save_figure

    out.mkdir(parents=True, exist_ok=True)
    columns, rows = plan_rows(points)
    written = [write_output(out / "plan.csv", csv_text(columns, rows), option="--out", inputs=inputs)]
    figure = plan_figure(points, worlds)
    for suffix in FIGURE_FORMATS:
        save_figure(figure, out / f"plan{suffix}", option="--out", inputs=inputs)
        written.append(out / f"plan{suffix}")
    return written


def plan_table(points: list[PlanPoint], grid: PlanGrid) -> Table:
    """A row per world and grid point: the shares and the median width of each pooled interval."""
    symbols = list(dict.fromkeys(s for p in points for s in p.symbols))
    hand = (f"a calibration block of {grid.calibration} targets each, the hand held fixed" if grid.calibration
            else "the hand estimated from play")
    table = Table(title=Text(f"study plan: {grid.repeats} simulated studies per row (players "
                             f"{', '.join(grid.players)}, spread {grid.spread:g}; {hand}; " + (
                                 f"{grid.model} model, Laplace intervals" if grid.fits == "plan" else
                                 f"fitted as study report fits them, {grid.resamples} resamples")
                             + f", {grid.pool} pool)"),
                  caption=Text("separated: the pooled hazard interval lies below the nuisance's; covered: every "
                               "pooled interval holds its hypothesised reward; width: the median width of the pooled "
                               f"{grid.confidence:.0%} interval"),
                  header_style="bold", box=box.SIMPLE_HEAD, padding=(0, 1))
    for name in ("world", "participants", "episodes", "separated", "covered"):
        table.add_column(name, justify="left" if name == "world" else "right")
    for s in symbols:
        table.add_column(f"width {SYMBOL_NAMES.get(s, printable(s))}", justify="right")
    for p in points:
        table.add_row(Text(printable(p.world, limit=30)), str(p.participants), str(p.episodes),
                      "-" if p.separated is None else f"{p.separated:.0%}", f"{p.covered:.0%}",
                      *(f"{p.width[s]:.0f}" if s in p.width else "" for s in symbols))
    return table


def plan_findings(points: list[PlanPoint], *, target: float = 0.8, confidence: float = 0.95,
                  fits: str = "plan") -> list[str]:
    """Per world, the smallest study (fewest participants x episodes) that separates in at least `target`
    of the simulated studies, or that none of the grid does; and how often the pool covered the truth (with the
    plan's own `fits`, a floor for a report's)."""
    lines = []
    for world in dict.fromkeys(p.world for p in points):
        mine = [p for p in points if p.world == world]
        name = printable(world, limit=30)
        worst = min(p.covered for p in mine)
        best = max(p.covered for p in mine)
        shares = f"{worst:.0%}" if f"{worst:.0%}" == f"{best:.0%}" else f"{worst:.0%} to {best:.0%}"
        cover = (f"every pooled interval held the hypothesised rewards in {shares} of studies"
                 + ("" if worst >= target else (
                     f": the plan's Laplace intervals miss the truth more often than their {confidence:.0%} says"
                     f"{_most_missed(mine)}; read the share as a floor for a report, whose bootstrap intervals are "
                     "wider (--fits report measures a report's)" if fits == "plan" else
                     f": the reports' intervals miss the truth more often than their {confidence:.0%} says"
                     f"{_most_missed(mine)}")))
        if mine[0].separated is None:
            lines.append(f"{name}: no hazard and nuisance to separate; {cover}.")
            continue
        good = [p for p in mine if p.separated is not None and p.separated >= target]
        if good:
            p = min(good, key=lambda q: (q.participants * q.episodes, q.participants))
            lines.append(f"{name}: {p.participants} participants of {p.episodes} episodes separate catastrophe "
                         f"from nuisance in {p.separated:.0%} of simulated studies, the smallest study here to "
                         f"reach {target:.0%}; {cover}.")
        else:
            top = max(mine, key=lambda q: q.separated or 0.0)
            lines.append(f"{name}: no study of this grid separates catastrophe from nuisance in {target:.0%} of "
                         f"simulated studies (the most: {top.separated:.0%}, {top.participants} participants of "
                         f"{top.episodes} episodes); {cover}.")
    return lines


def _most_missed(points: list[PlanPoint]) -> str:
    """" (the most: the cliff's held -1000 in 5% at 10 participants of 10 episodes)": the symbol and grid point
    whose pooled interval held its reward least often."""
    share, symbol, p = min(((p.covered_each[s], s, p) for p in points for s in p.symbols), key=lambda t: t[:2])
    truth = dict(zip(p.symbols, p.truth))[symbol]
    return (f" (the least: the {SYMBOL_NAMES.get(symbol, printable(symbol))}'s held {truth:g} in {share:.0%}, at "
            f"{p.participants} participants of {p.episodes} episodes)")
