"""`careful check FILE...`: the coverage of a fit's intervals on the user's own design (docs/check.md).

Fits the recordings as `careful fit` would (intervals on), then `irl_core.coverage.check` simulates datasets
of their size from the fit and from rival players and refits each: a progress bar on stderr while they come
back, the coverage table and a verdict per player on stdout, and ``<out>/check.csv`` and the scales that would
bring every player to the level, ``<out>/calibration.json`` (`irl_core.coverage.calibrate`; not for a fit
already calibrated, whose check measures the widened intervals), each written whole through the output guard
(replaced where an earlier one is, as `careful study report` replaces its report.csv; Ctrl+C leaves the old
file or none, never part of a new one).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from rich import box
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from careful_tui.commands.fit import fit_from_args
from careful_tui.errors import EXIT_FAILURE, EXIT_OK
from careful_tui.option_words import said
from irl_core.coverage.calibrate import calibration_of
from irl_core.coverage.check import CSV_COLUMNS, CheckResult, coverage_band, run_check
from irl_core.coverage.rivals import default_rivals, rivals_for
from irl_core.errors import SchedulerError, SolverError, UsageError
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.csv_cells import csv_text
from irl_core.support.executor import close, scheduler
from irl_core.support.plural import plural
from irl_core.support.safe_files import check_output, check_output_folder, write_output
from irl_core.support.safe_text import printable

CHECK_CSV = "check.csv"
CALIBRATION_JSON = "calibration.json"


def run_check_command(args: argparse.Namespace) -> int:
    err = Console(stderr=True, highlight=False)
    named = args.players  # checked at parse time against every player; against the world's once it is read
    out = check_output_folder(args.out, option="--out")
    inputs = [*args.files, *filter(None, [args.calibration])]
    if out.is_dir():
        # A calibrated fit's check measures its intervals and learns no new calibration (it would compound).
        for name in (CHECK_CSV,) if args.calibration is not None else (CHECK_CSV, CALIBRATION_JSON):
            check_output(out / name, option="--out", inputs=inputs)
    args.intervals = True  # a check measures the intervals: the refits have them, so the fit does too
    chosen: list[tuple[str, ...]] = []

    def choose_rivals(demos: Demonstrations) -> None:
        world = demos.mdp.world
        chosen.append(rivals_for(default_rivals(world) if named is None else named, world))

    try:
        demos, result = fit_from_args(args, err=err, before_fit=choose_rivals)
    except SolverError as exc:
        err.print(Text(f"careful check: {said(exc)}", style="bold red"), soft_wrap=True)
        return EXIT_FAILURE
    rivals = chosen[0]
    try:
        executor = scheduler(args.scheduler, workers=args.workers) if args.scheduler is not None else None
    except SchedulerError as exc:
        raise UsageError(f"--scheduler {printable(str(exc), limit=300)}") from None
    start = time.perf_counter()
    try:
        with Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                      TimeElapsedColumn(), console=err, transient=True) as progress:
            task = progress.add_task(f"simulating and refitting {plural(args.datasets, 'dataset')} per player",
                                     total=None)
            checked = run_check(result, demos, rivals=rivals, datasets=args.datasets, seed=args.seed,
                                executor=executor, workers=args.workers or os.cpu_count() or 1,
                                progress=lambda done, total: progress.update(task, completed=done, total=total))
    finally:
        if executor is not None:
            close(executor)
    elapsed = time.perf_counter() - start
    out.mkdir(parents=True, exist_ok=True)
    path = write_output(out / CHECK_CSV, csv_text(CSV_COLUMNS, checked.csv_rows()), option="--out", inputs=inputs)
    console = Console(highlight=False)
    console.print(coverage_table(checked, unit=result.reward_unit))
    for line in verdict_lines(checked):
        console.print(Text(line), soft_wrap=True)
    if result.options.calibration is None:
        calibration = calibration_of(result, checked.scales, players=tuple(checked.verdicts), datasets=args.datasets,
                                     seed=args.seed)
        written = write_output(out / CALIBRATION_JSON, json.dumps(calibration.to_json(), indent=2) + "\n",
                               option="--out", inputs=inputs)
        console.print(Text(scales_line(checked, written)), soft_wrap=True)
    else:
        console.print(Text("these are the calibrated intervals' coverage (--calibration): no new calibration is "
                           "learned from them"), soft_wrap=True)
    err.print(Text(f"wrote {printable(str(path), limit=160)}: {plural(len(rivals) + 1, 'player')} x "
                   f"{plural(args.datasets, 'dataset')} of {plural(demos.episodes, 'episode')}, refitted in "
                   f"{elapsed:.1f} s"), soft_wrap=True)
    return EXIT_OK


def coverage_table(checked: CheckResult, *, unit: str) -> Table:
    """The rows of check.csv as a table, with what they mean in its caption."""
    table = Table(box=box.SIMPLE_HEAD, caption=(
        f"coverage: the share of datasets whose {checked.confidence:.0%} intervals held the reward they were "
        f"simulated with (per cell: every cell of the symbol); width and error (fitted minus truth) in {unit}, "
        "medians over the datasets"), caption_justify="left")
    for column in ("player", "rival", "symbol", "datasets", "covered", "coverage", "median width", "median error"):
        table.add_column(column, justify="left" if column in ("player", "rival", "symbol") else "right")
    for row in checked.rows:
        table.add_row(printable(row.player), "yes" if row.rival else "no", printable(row.symbol), str(row.datasets),
                      str(row.covered), "-" if not row.datasets else f"{row.coverage:.0%}",
                      "-" if not row.datasets else f"{row.median_width:.3g}",
                      "-" if not row.datasets else f"{row.median_error:+.3g}")
    return table


def scales_line(checked: CheckResult, path: Path) -> str:
    """The learned scales and where they were written, with how to use them."""
    scales = ", ".join(f"{printable(symbol)} x{scale:.3g}" if scale is not None else
                       f"{printable(symbol)} none (the whole range)" for symbol, scale in checked.scales.items())
    return (f"calibration: half-widths around the point widened {scales} would have held the truth in at least "
            f"{checked.confidence:.0%} of the datasets of every player checked; written to "
            f"{printable(str(path), limit=160)} (fit with --intervals --calibration {printable(str(path), limit=160)})")


def verdict_lines(checked: CheckResult) -> list[str]:
    """A verdict per player, with the band it was judged by and the datasets that had no intervals."""
    low, high = coverage_band(checked.datasets, checked.confidence)
    lines = []
    for player, said_of in checked.verdicts.items():
        problems = checked.problems.get(player)
        lost = "" if not problems else "; left out: " + ", ".join(
            f"{plural(count, 'dataset')} ({problem})" for problem, count in problems.items())
        lines.append(f"{player}: {said_of} (nominal is {low} to {high} of {checked.datasets} datasets covered, the "
                     f"central 95% of Binomial({checked.datasets}, {checked.confidence:g})){lost}")
    return lines
