"""`careful study report STUDY.toml`: per participant and pooled fits per world (docs/studies.md).

The computation is `irl_core.studies.report`; this module prints it with Rich (a progress bar
on stderr, the table on stdout) and writes the CSV and the figures under ``<out>/report/``
(or ``--out``), every file through the output guard. A file that cannot be used is named on
stderr (``file:line: field: problem``) and left out; the report goes on with the rest.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field
from pathlib import Path

from rich import box
from rich.console import Console, Group
from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

import irl_core.irl.choices as choices
from careful_tui.errors import EXIT_OK
from careful_tui.option_words import said
from careful_tui.render.grid import SYMBOL_NAMES, format_value
from careful_tui.render.session import outcome_words
from irl_core.errors import ClusterLost, SchedulerError, StudyError, UsageError
from irl_core.irl import at_bound
from irl_core.irl.notes import CODES
from irl_core.irl.options import FitOptions
from irl_core.studies.report import (
    POOLED,
    Cell,
    CellFit,
    StudyData,
    fit_report,
    gather,
    pooled_finding,
    report_options,
    report_rows,
    report_symbols,
)
from irl_core.studies.study import Exclusions, LoadedStudy, load_study, world_files
from irl_core.support.csv_cells import csv_text
from irl_core.support.executor import Executor, close, scheduler
from irl_core.support.plural import plural
from irl_core.support.safe_files import check_output_folder, write_output
from irl_core.support.safe_text import printable

FIGURE_FORMATS = (".png", ".pdf")
# The codes of the fits' notes on what the table shows already (the method, beta) or that say all is well.
TABLE_NOTES = frozenset({"auto_chose", "beta_estimated", "beta_interval", "player_model", "player_estimated",
                         "fit_check_passed"})
# The tables are laid out for a terminal this wide, and a file or a pipe gets them so (rows of a typical study fit).
TABLE_WIDTH = 100
INFLUENTIAL_MARK = "†"
OUTLIER_MARK = "‡"
CHECK_FAILED_MARK = "✗"
EXCLUDED_MARK = "(excluded)"
PREDICTION_ROW = "95% prediction"
WRAPPING_COLUMNS = ("outcomes", "fit")


@dataclass
class Timings:
    """Seconds each part of a report took."""

    reading: float = 0.0
    fits: float = 0.0
    figures: float = 0.0
    written: list[Path] = field(default_factory=list)


def run_study_report(args: argparse.Namespace) -> int:
    err = Console(stderr=True, highlight=False)
    options = report_options(resamples=args.resamples, seed=args.seed, rmax=args.rmax)
    pool_model = choices.pool_model(args.pool_model)
    if problem := options.problem():
        raise UsageError(said(problem))
    try:
        study = load_study(args.study)
    except StudyError as exc:
        raise UsageError(str(exc)) from None
    out = check_output_folder(args.out if args.out is not None else study.report_folder, option="--out")
    try:
        executor = scheduler(args.scheduler, workers=args.workers)
    except SchedulerError as exc:
        raise UsageError(f"--scheduler {printable(str(exc), limit=300)}") from None
    try:
        return _report(args, study, out, options, executor, err, pool_model=pool_model)
    except ClusterLost as exc:  # every worker, or the scheduler, gone mid-report: nothing was written
        raise UsageError(f"--scheduler {printable(str(exc), limit=600)}; nothing written") from None
    finally:
        close(executor)


def _report(args: argparse.Namespace, study: LoadedStudy, out: Path, options: FitOptions, executor: Executor,
            err: Console, *, pool_model: str) -> int:
    """The report of `study` into `out`, its fits on `executor`."""
    timings = Timings()
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=err, transient=True) as progress:
        task = progress.add_task("reading participants", total=None)
        start = time.perf_counter()
        data = gather(study, progress=lambda done, total: progress.update(task, completed=done, total=total))
        timings.reading = time.perf_counter() - start
        if not data.participants:
            raise UsageError(f"{study.out}: no participant folders: nothing to report (run the study, or write "
                             "simulated participants, first)")
        for warning in data.problems:
            err.print(Text(f"warning: {printable(warning, limit=400)}", style="yellow"), soft_wrap=True)
        progress.update(task, description=f"fitting (each world's pool, then its participants; pooled as "
                        f"{pool_model})", completed=0, total=None)
        start = time.perf_counter()
        exclusions = Exclusions() if args.no_exclusions else None
        fits = fit_report(data, options, pool_model=pool_model, exclusions=exclusions, workers=args.workers,
                          executor=executor,
                          progress=lambda done, total: progress.update(task, completed=done, total=total))
        timings.fits = time.perf_counter() - start
        progress.update(task, description="drawing figures", completed=0, total=None)
        start = time.perf_counter()
        try:
            timings.written = write_report(data, fits, out)
        except OSError as exc:
            raise UsageError(f"--out {printable(str(out), limit=160)}: cannot write there "
                             f"({exc.strerror or exc})") from None
        timings.figures = time.perf_counter() - start
    # The table goes out once the progress display on stderr is gone, so the two never interleave.
    out_console = Console(highlight=False)
    if not out_console.is_terminal:
        out_console.width = TABLE_WIDTH  # a file or a pipe: as a terminal of 100 columns, not wrapped at 80
    out_console.print(report_table(data, fits))
    for legend in mark_legends(fits):
        out_console.print(Text(legend), soft_wrap=True)
    for line in exclusion_lines(data, fits, ignored=args.no_exclusions and study.study.exclusions.any_set):
        out_console.print(Text(line), soft_wrap=True)
    for finding in findings(data, fits):
        out_console.print(Text(finding), soft_wrap=True)
    for note in fit_notes(data, fits):
        out_console.print(Text(f"note: {note}"), soft_wrap=True)
    err.print(Text(
        f"wrote {len(timings.written)} files to {printable(str(out), limit=160)} (report.csv and figures); "
        f"{plural(len(data.participants), 'participant')}, pooled as {pool_model}; reading {timings.reading:.1f} s, "
        f"fits {timings.fits:.1f} s, figures {timings.figures:.1f} s" + left_out_text(data)),
        soft_wrap=True)
    return EXIT_OK


def left_out_text(data: StudyData) -> str:
    """"; 1 file and 2 folders left out (named above the tables)", or "" when nothing was."""
    counts = [(sum(data.left_out.values()), "file"), (data.folders_left_out, "folder")]
    said = " and ".join(plural(n, word) for n, word in counts if n)
    return f"; {said} left out (named above the tables)" if said else ""


def write_report(data: StudyData, fits: list[CellFit], out: Path) -> list[Path]:
    """The CSV and every figure, in `out` (through the output guard); returns the files written."""
    inputs = [data.study.path, *world_files(data.study)]  # recordings are refused by the guard anyway
    out.mkdir(parents=True, exist_ok=True)
    columns, rows = report_rows(data, fits)
    written = [write_output(out / REPORT_CSV, csv_text(columns, rows), option="--out", inputs=inputs)]
    from careful_tui.render.figures.study_figures import report_figures
    from careful_tui.render.figures.style import save_figure

    for name, figure in report_figures(data, fits):
        for suffix in FIGURE_FORMATS:
            path = out / f"{name}{suffix}"
            save_figure(figure, path, option="--out", inputs=inputs)
            written.append(path)
    return written


def symbol_name(symbol: str) -> str:
    return SYMBOL_NAMES.get(symbol, printable(symbol))


def interval_caption(fits: list[CellFit]) -> str:
    """What the bracketed intervals are, from the kinds this report holds."""
    kinds = []
    if any(f.interval_kind == "confidence" for f in fits):
        confidence = next(f.confidence for f in fits if f.interval_kind == "confidence")
        pooled = ("a population's row: its centre's interval from the participants' fits, each with their own "
                  "player" if any(f.pool_model == "population" for f in fits) else
                  "a pool's resamples participants, then their episodes")
        kinds.append(f"{confidence:.0%} confidence interval (bootstrap over episodes; {pooled}) for maxent and "
                     "loss fits")
    if any(f.interval_kind == "identified" for f in fits):
        kinds.append("identified set for lp fits")
    return "[low, high]: " + "; ".join(kinds) if kinds else "No intervals could be computed"


def played_caption(data: StudyData) -> str:
    """What the first table's columns and marks mean, and what the participants were shown."""
    careful = "Careful: mean carefulness level one step from a terminal cell"
    if any(cell.hold_ms_next_to_terminal is not None for cell in data.cells):
        careful += " (on a time world, the geometric mean hold)"
    parts = [careful, "Episodes quit or unfinished are counted, not fitted", shown_text(data.study)]
    if data.left_out:
        parts.append("*: a file of this participant was left out (named above the tables)")
    return ". ".join(parts) + "."


def shown_text(study: LoadedStudy) -> str:
    """What the board's legend told every participant, from the study file's ``show_rewards``."""
    if study.study.show_rewards:
        return "Participants saw each symbol's reward in the board's legend (the study file's show_rewards = true)"
    return "Participants saw the symbols' names only, no rewards (the study file's show_rewards = false)"


def rewards_caption(fits: list[CellFit]) -> str:
    """What the second table's brackets mean, as far as this report has them."""
    parts = [interval_caption(fits)]
    if any(f.prediction is not None for f in fits):
        parts.append(f"{PREDICTION_ROW}: where a new participant's rewards would lie, from the population's "
                     "prediction interval")
    boxed = [f for f in fits if f.intervals is not None and at_bound(f.intervals, f.rmax).any()]
    if boxed:
        parts.append(f"An end at ±{boxed[0].rmax:g} is the fit's bound (--rmax), not a bound from the data")
    return ". ".join(parts) + "."


def careful_text(cell: Cell) -> str:
    """The table's careful column: the mean level, or on a time world the geometric mean hold, one step from danger."""
    if cell.hold_ms_next_to_terminal is not None:
        return f"{cell.hold_ms_next_to_terminal:.0f} ms"
    return "" if cell.careful_next_to_terminal is None else f"{cell.careful_next_to_terminal:.1f}"


def report_table(data: StudyData, fits: list[CellFit]) -> Group:
    """The report's two tables, each readable in `TABLE_WIDTH` columns: how each participant played and was
    fitted (`played_table`), then the fitted rewards with their intervals (`rewards_table`). The CSV has every
    column in one table."""
    return Group(played_table(data, fits), Text(""), rewards_table(data, fits))


def _titled(title: str, caption: str) -> Table:
    return Table(title=Text(title), caption=Text(caption), header_style="bold", box=box.SIMPLE_HEAD, padding=(0, 1))


def _who(data: StudyData, cell: Cell, result: CellFit, *, marked: bool = True) -> Text:
    """The first column: the participant (with their marks, where `marked`), or the pool."""
    pooled = cell.participant == POOLED
    if pooled:
        who = f"population ({result.pooled})" if result.pooled is not None else f"pooled ({cell.participants})"
    else:
        who = cell.participant + (" *" if data.left_out.get(cell.participant) else "")
    for mark, has in ((INFLUENTIAL_MARK, result.influential), (OUTLIER_MARK, result.outlier),
                      (CHECK_FAILED_MARK, result.fit_check_passed is False), (EXCLUDED_MARK, bool(result.excluded_why))):
        if has and marked:
            who += f" {mark}"
    return Text(who, style="bold" if pooled else "")


def _rows(data: StudyData, fits: list[CellFit], table: Table):
    """Each cell and its fit, world by world (a section each), with the row's style."""
    previous_world = None
    for cell, result in zip(data.cells, fits):
        if previous_world is not None and cell.world_index != previous_world:
            table.add_section()
        previous_world = cell.world_index
        pooled = cell.participant == POOLED
        yield cell, result, "bold" if pooled else ("dim" if result.excluded_why else None)


def played_table(data: StudyData, fits: list[CellFit]) -> Table:
    """A row per participant and world, then the world's pool: episodes, outcomes, carefulness, the fit."""
    table = _titled(f"study {printable(data.study.study.name, limit=80)}: main-phase episodes, fitted per participant "
                    "and pooled", played_caption(data))
    # The short columns never wrap (an id is never cut); the outcomes and the fit wrap within their cells when the
    # terminal is narrow. The marks are on this table's rows, beside the fit they qualify.
    table.add_column("participant", no_wrap=True, overflow="fold")
    for name in ("world", "episodes", "outcomes", "careful", "fit"):  # steps are in the CSV
        table.add_column(name, justify="right" if name in ("episodes", "careful") else "left",
                         no_wrap=name not in WRAPPING_COLUMNS)
    for cell, result, style in _rows(data, fits, table):
        table.add_row(
            _who(data, cell, result), Text(printable(data.study.worlds[cell.world_index].name, limit=40)),
            str(cell.episodes), Text(outcomes_text(cell.outcomes, cell.interrupted_outcomes)),
            careful_text(cell), Text(fit_text(result), style="red" if result.error else ""), style=style)
    return table


def rewards_table(data: StudyData, fits: list[CellFit]) -> Table:
    """The same rows' fitted rewards per symbol with intervals, and a population's prediction for a new participant
    (the rows' marks are in `played_table`: each reward column keeps its room)."""
    symbols = report_symbols(data.study, fits)
    table = _titled("fitted rewards per participant and pooled", rewards_caption(fits))
    table.add_column("participant", no_wrap=True, overflow="fold")
    table.add_column("world", no_wrap=True)
    for symbol in symbols:
        table.add_column(symbol_name(symbol), justify="right")
    for cell, result, style in _rows(data, fits, table):
        table.add_row(_who(data, cell, result, marked=False),
                      Text(printable(data.study.worlds[cell.world_index].name, limit=40)),
                      *(Text(reward_text(result, symbol)) for symbol in symbols), style=style)
        if cell.participant == POOLED and result.prediction is not None:
            table.add_row(Text(f"  {PREDICTION_ROW}"), "", *(Text(prediction_text(result, symbol)) for symbol in symbols))
    return table


def prediction_text(result: CellFit, symbol: str) -> str:
    """A population's prediction interval for a new participant's `symbol`: "[-2900, -310]"."""
    if result.prediction is None or symbol not in result.symbols:
        return ""
    low, high = result.prediction[result.symbols.index(symbol)]
    return f"[{format_value(float(low))}, {format_value(float(high))}]"


def mark_legends(fits: list[CellFit]) -> list[str]:
    """The marks' legend lines under the table, one for each mark some row has."""
    legends = []
    if any(f.influential for f in fits):
        legends.append(f"{INFLUENTIAL_MARK} influential: the pooled centre with this participant lies outside the "
                       "pool's interval without them, or the other way round")
    if any(f.outlier for f in fits):
        legends.append(f"{OUTLIER_MARK} outlier: this participant's fit lies outside where the other participants say "
                       "a participant's fit would lie (their population's prediction, this fit's own noise included)")
    if any(f.fit_check_passed is False for f in fits):
        legends.append(f"{CHECK_FAILED_MARK} fit check failed: the fitted player does not reproduce this participant's "
                       "recordings, so their numbers are not explained by the model")
    return legends


def exclusion_lines(data: StudyData, fits: list[CellFit], *, ignored: bool) -> list[str]:
    """Who the study's exclusions left out of the pools and why, or that --no-exclusions ignored them."""
    if ignored:
        return ["The study file's [exclusions] were not applied (--no-exclusions): every participant is pooled."]
    lines = []
    for cell, result in zip(data.cells, fits):
        if result.excluded_why:
            world = printable(data.study.worlds[cell.world_index].name, limit=40)
            lines.append(f"excluded from the {world} pool by the study's [exclusions]: {cell.participant} "
                         f"({printable(result.excluded_why, limit=200)})")
    return lines


def findings(data: StudyData, fits: list[CellFit]) -> list[str]:
    """What each world's pooled row shows, a sentence each (`pooled_finding`)."""
    return [printable(pooled_finding(data, cell, result), limit=600)
            for cell, result in zip(data.cells, fits) if cell.participant == POOLED]


def fit_notes(data: StudyData, fits: list[CellFit]) -> list[str]:
    """The fits' notes that qualify their numbers (too few episodes for a bootstrap, beta not
    identified, ...), each once with the rows it applies to: "only 4 episodes: ...: p1 · paper, p2 · paper".
    Notes of what the table shows already (why auto chose the method, beta) are left out; the CSV keeps them
    all, beta's interval too."""
    where: dict[str, dict[str, list[str]]] = {}  # code -> text -> rows
    for cell, result in zip(data.cells, fits):
        world = printable(data.study.worlds[cell.world_index].name, limit=40)
        for note in result.notes:
            if note.code not in TABLE_NOTES:
                where.setdefault(note.code, {}).setdefault(str(note), []).append(f"{cell.participant} · {world}")
        if result.error and cell.participant != POOLED and fit_text(result) != result.error:
            # The table shows the reason's first clause; a pool's whole reason is its finding.
            where.setdefault("", {}).setdefault(f"not fitted: {result.error}", []).append(f"{cell.participant} · {world}")
    lines = []
    for code, texts in where.items():
        if len(texts) > SPELLED_OUT and code in CODES:
            # Each row's own numbers (a hand from its trials, a fit check's statistic): one line, not one per row.
            rows = [row for rows in texts.values() for row in rows]
            lines.append(f"{CODES[code]} ({plural(len(rows), 'row')}, each with its own numbers in {REPORT_CSV}'s "
                         f"note column): {_first_rows(rows)}")
        else:
            lines += [f"{printable(text, limit=300)}: {_first_rows(rows)}" for text, rows in texts.items()]
    return lines


REPORT_CSV = "report.csv"
# A note whose words differ on more rows than this (each row's own numbers) is said once for all of them.
SPELLED_OUT = 3


def _first_rows(rows: list[str], shown: int = 6) -> str:
    return ", ".join(rows[:shown]) + (f" and {len(rows) - shown} more" if len(rows) > shown else "")


def outcomes_text(outcomes: dict[str, int], interrupted: dict[str, int]) -> str:
    """How episodes ended, in the words replay and play use, the fitted ones first:
    "8 reached the goal, 1 ran out of steps; 1 quit, 1 unfinished" (by `outcome_code`)."""
    def counted(by_code: dict[str, int]) -> str:
        # Terminal symbols in name order, then the step limit (or quit, then unfinished).
        codes = sorted(by_code, key=lambda code: (code in ("step_limit", "unfinished"), code))
        return ", ".join(f"{by_code[code]} {printable(outcome_words(code))}" for code in codes if by_code[code])

    text = counted(outcomes) or "-"
    return text + (f"; {counted(interrupted)}" if any(interrupted.values()) else "")


def fit_text(result: CellFit) -> str:
    """The method and its beta ("maxent β 0.43"), or why there is no fit."""
    if result.error:  # its first clause; the whole reason is under the table (`fit_notes`, `findings`)
        return printable(result.error.split(";")[0], limit=100)
    if result.beta is not None:
        return f"{result.method} β {result.beta:.2g}{'' if result.beta_auto else ' (fixed)'}"
    return result.method


def reward_text(result: CellFit, symbol: str) -> str:
    """ "-1020 [-1800, -600]", or "-" where this fit has no such symbol."""
    if symbol not in result.symbols:
        return ""
    j = result.symbols.index(symbol)
    text = format_value(float(result.estimate[j]))
    if result.intervals is not None:
        low, high = result.intervals[j]
        text += f" [{format_value(float(low))}, {format_value(float(high))}]"
    return text
