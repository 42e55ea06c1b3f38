"""A study's report (README "Studies"), as plain data: per participant and pooled fits per world.

`gather` reads every participant folder under the study's ``out`` and keeps each one's
finished main-phase episodes per world (practice never enters a fit; an interrupted episode
is counted, not fitted; see `irl_core.study`). A file that cannot be used is named in
`StudyData.problems` and left out; the participant's other files are still reported.
`run_fits` fits every (participant, world) and every world's pool in one process pool across
the cores; each fit's bootstrap runs inside its worker (``workers=1``), so the cores are not
asked for twice. `report_rows` is the table the command prints and writes as CSV.
"""

from __future__ import annotations

import dataclasses
import os
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from irl_core.csv_cells import text_cell
from irl_core.demonstrations import Demonstrations, Recording
from irl_core.end_table import EndTable
from irl_core.irl import FitError, FitOptions, fit
from irl_core.pool import run_in_pool
from irl_core.step_table import StepTable
from irl_core.stopping import stop_check
from irl_core.study import POOLED, REPORT_FOLDER, LoadedStudy, StudyError, check_participant, finished_episodes, \
    interrupted_episodes, read_participant
from irl_core.summary import distance_to_terminal, outcome_code


def report_options(*, resamples: int = 200, seed: int = 0, rmax: float = 5000.0) -> FitOptions:
    """The report's fits: the auto method's choice (docs/answers.md; maxent with beta estimated for a person's noisy play),
    one reward per symbol, with intervals (a bootstrap confidence interval for maxent)."""
    return FitOptions(method="auto", tie=True, intervals=True, resamples=resamples, seed=seed, rmax=rmax)


@dataclass(frozen=True)
class Cell:
    """One participant's (or the pool's) finished main episodes of one world.

    Attributes:
        participant: the id, or `POOLED` for everyone's episodes of the world together.
        world_index: the world's index in the study file.
        demos: the finished main episodes as demonstrations (None when there are none).
        episodes: finished main episodes (the ones fitted).
        steps: their steps.
        outcomes: finished episodes per `irl_core.summary.outcome_code` (a terminal symbol, or
            ``step_limit``).
        interrupted_outcomes: main episodes with steps that did not finish (not fitted), per
            outcome code (``quit``, or ``unfinished``: no end recorded).
        careful_next_to_terminal: mean carefulness of the steps taken next to a terminal cell
            (one grid step away), or None when there were none.
        participants: how many participants the cell holds (1, or how many have episodes in the pool).
    """

    participant: str
    world_index: int
    demos: Demonstrations | None
    episodes: int
    steps: int
    outcomes: dict[str, int]
    interrupted_outcomes: dict[str, int]
    careful_next_to_terminal: float | None
    participants: int = 1

    @property
    def interrupted(self) -> int:
        """Main episodes quit or cut off (counted, not fitted)."""
        return sum(self.interrupted_outcomes.values())


@dataclass(frozen=True)
class StudyData:
    """Every cell of the report (world by world: participants in name order, then the pool), and
    the files left out."""

    study: LoadedStudy
    participants: tuple[str, ...]
    cells: tuple[Cell, ...]
    problems: tuple[str, ...]
    left_out: dict[str, int]  # participant -> files left out (participants with none are not listed)
    folders_left_out: int = 0  # folders under out whose names cannot be participant ids

    def cell(self, participant: str, world_index: int) -> Cell:
        return next(c for c in self.cells if c.participant == participant and c.world_index == world_index)


def participant_ids(study: LoadedStudy) -> tuple[list[str], list[str]]:
    """The participant folders under the study's ``out`` (name order), and one line per folder
    that cannot be a participant's."""
    ids, problems = [], []
    if not study.out.is_dir():
        return ids, problems
    for folder in sorted(p for p in study.out.iterdir() if p.is_dir()):
        if folder.name == REPORT_FOLDER:
            continue
        try:
            ids.append(check_participant(folder.name))
        except StudyError as exc:
            problems.append(f"{folder}: {exc}; left out")
    return ids, problems


def gather(study: LoadedStudy, *, progress: Callable[[int, int], None] | None = None) -> StudyData:
    """Read every participant's main-phase recordings into cells (see `Cell`).

    Args:
        progress: called as progress(participants read, participants) after each participant.
    """
    ids, problems = participant_ids(study)
    folders_left_out = len(problems)
    per_world: dict[int, list[Recording]] = {i: [] for i in range(len(study.worlds))}
    cells, left_out = [], {}
    for n, participant in enumerate(ids, 1):
        found = read_participant(study, participant)
        problems.extend(found.problems)
        if found.left_out:
            left_out[participant] = found.left_out
        mine: dict[int, list[Recording]] = {i: [] for i in range(len(study.worlds))}
        for tag, recording in found.recordings:
            if tag.phase == "main":
                mine[tag.world_index].append(recording)
        for world_index, recordings in mine.items():
            cells.append(_cell(study, participant, world_index, recordings))
            per_world[world_index].extend(recordings)
        if progress:
            progress(n, len(ids))
    for world_index, recordings in per_world.items():
        pooled = _cell(study, POOLED, world_index, recordings)
        contributing = sum(1 for cell in cells if cell.world_index == world_index and cell.episodes)
        cells.append(dataclasses.replace(pooled, participants=contributing))
    # World by world: its participants in name order, then its pool.
    cells.sort(key=lambda cell: (cell.world_index, cell.participant == POOLED))
    return StudyData(study=study, participants=tuple(ids), cells=tuple(cells), problems=tuple(problems),
                     left_out=left_out, folders_left_out=folders_left_out)


def _finished_only(recording: Recording) -> Recording:
    """The recording with only its finished episodes (steps and ends)."""
    keep = finished_episodes(recording)
    steps = StepTable()
    for step in recording.steps:
        if step.episode in keep:
            steps.append(step)
    ends = EndTable(end for end in recording.episode_ends if end.episode in keep)
    return dataclasses.replace(recording, steps=steps, episode_ends=ends, warnings=[])


def _cell(study: LoadedStudy, participant: str, world_index: int, recordings: list[Recording]) -> Cell:
    interrupted: Counter[str] = Counter()
    for recording in recordings:
        ends = {end.episode: end for end in recording.episode_ends}
        interrupted.update(outcome_code(ends.get(episode)) for episode in interrupted_episodes(recording))
    finished = [_finished_only(r) for r in recordings]
    outcomes = Counter(outcome_code(end) for recording in finished for end in recording.episode_ends)
    world = study.worlds[world_index]
    near = {cell for cell, d in distance_to_terminal(world).items() if d == 1}
    levels = [step.carefulness for r in finished for step in r.steps if step.state in near]
    steps = sum(len(r.steps) for r in finished)
    demos = Demonstrations.from_recordings(finished) if steps else None
    return Cell(participant=participant, world_index=world_index, demos=demos,
                episodes=sum(len(r.episode_ends) for r in finished), steps=steps, outcomes=dict(outcomes),
                interrupted_outcomes=dict(interrupted), careful_next_to_terminal=float(np.mean(levels)) if levels else None)


# ---------------------------------------------------------------------------- fits


@dataclass(frozen=True)
class CellFit:
    """What the report keeps of one fit (small, to come back from a worker process).

    Attributes:
        symbols: (k,) the fitted symbols (one unknown per symbol).
        estimate: (k,) the fitted reward per symbol.
        intervals: (k, 2) [low, high] per symbol, or None when not computed (see `notes`).
        truth: (k,) the world file's reward per symbol.
        interval_kind: ``confidence`` (maxent, loss) or ``identified`` (lp), None without intervals.
        reward_grid: (rows, cols) fitted R_S, NaN at walls.
        error: why there is no fit (then the other fields are empty), else None.
    """

    method: str = ""
    beta: float | None = None
    beta_auto: bool = False
    symbols: tuple[str, ...] = ()
    estimate: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    intervals: np.ndarray | None = None
    truth: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    interval_kind: str | None = None
    confidence: float = 0.95
    rmax: float = 0.0
    reward_grid: np.ndarray | None = None
    notes: tuple[str, ...] = ()
    elapsed_s: float = 0.0
    error: str | None = None


def fit_cell(cell: Cell, options: FitOptions, *, stop: Callable[[], bool] | None = None) -> CellFit:
    """Fit one cell (its bootstrap in this process); a cell without steps or a failed fit gives an error.

    Raises:
        irl_core.stopping.Stopped: `stop()` became true during the fit.
    """
    if cell.demos is None:
        return CellFit(error="no finished main episodes")
    try:
        result = fit(cell.demos, options, workers=1, stop=stop)
    except FitError as exc:
        return CellFit(error=str(exc))
    return CellFit(method=result.method, beta=result.beta, beta_auto=result.beta_auto,
                   symbols=tuple(result.unknowns.symbols), estimate=result.theta.copy(),
                   intervals=None if result.intervals is None else np.asarray(result.intervals, dtype=float),
                   truth=result.unknowns.true_theta(result.mdp), interval_kind=result.interval_kind,
                   confidence=options.confidence, rmax=options.rmax, reward_grid=result.reward_grid,
                   notes=tuple(result.notes),
                   elapsed_s=result.elapsed_s)


def run_fits(cells: list[Cell], options: FitOptions, *, workers: int | None = None,
             progress: Callable[[int, int], None] | None = None) -> list[CellFit]:
    """Fit every cell, in a process pool of `workers` (default: the cores); results in `cells`' order.

    The biggest cells (the pools) are sent first, so the last fits to finish are small ones.
    """
    fits: list[CellFit | None] = [None] * len(cells)
    order = sorted(range(len(cells)), key=lambda i: -cells[i].steps)
    workers = max(1, min(workers or os.cpu_count() or 1, len(cells)))
    done = 0

    def returned(k: int, fitted: CellFit) -> None:
        nonlocal done
        fits[order[k]] = fitted
        done += 1
        if progress:
            progress(done, len(cells))

    if workers == 1:
        for k, i in enumerate(order):
            returned(k, fit_cell(cells[i], options))
    else:
        run_in_pool(_fit_in_worker, [(cells[i], options) for i in order], workers=workers, on_result=returned)
    return fits


def _fit_in_worker(cell: Cell, options: FitOptions) -> CellFit:
    """`fit_cell` in a worker of `run_in_pool`, stopping when the report is left (Ctrl+C)."""
    return fit_cell(cell, options, stop=stop_check())


# ---------------------------------------------------------------------------- the table


def report_symbols(study: LoadedStudy, fits: list[CellFit]) -> list[str]:
    """Every fitted symbol of any world, worst true reward first (cliff, mud, ..., goal)."""
    symbols = {s for f in fits for s in f.symbols}
    truth = {s: min(w.reward_of(s) for w in study.worlds if s in w.layout) for s in symbols}
    return sorted(symbols, key=lambda s: (truth[s], s))


def report_rows(data: StudyData, fits: list[CellFit]) -> tuple[list[str], list[list[str]]]:
    """The report's CSV: its columns and one row per cell (world by world: participants, then the pool).

    Columns: study, participant, world_index, world, episodes, steps, interrupted,
    ``ended_<T>`` per terminal symbol, step_limit, careful_next_to_terminal, method, beta,
    interval_kind, confidence, ``reward_<S>``, ``reward_<S>_low``, ``reward_<S>_high`` per
    fitted symbol, files_left_out, note. Empty where a value does not apply.
    """
    study = data.study
    terminals = sorted({t for w in study.worlds for t in w.terminal})
    symbols = report_symbols(study, fits)
    columns = ["study", "participant", "world_index", "world", "episodes", "steps", "interrupted",
               *(f"ended_{t}" for t in terminals), "step_limit", "careful_next_to_terminal", "method", "beta",
               "interval_kind", "confidence",
               *(f"reward_{s}{end}" for s in symbols for end in ("", "_low", "_high")), "files_left_out", "note"]
    rows = []
    for cell, result in zip(data.cells, fits):
        world = study.worlds[cell.world_index]
        rewards: list[str] = []
        for symbol in symbols:
            if symbol in result.symbols:
                j = result.symbols.index(symbol)
                low, high = ("", "") if result.intervals is None else (_number(v) for v in result.intervals[j])
                rewards += [_number(result.estimate[j]), low, high]
            else:
                rewards += ["", "", ""]
        terminal_counts = [str(cell.outcomes.get(t, 0)) if t in world.terminal else "" for t in terminals]
        rows.append([
            text_cell(study.study.name), cell.participant, str(cell.world_index), text_cell(world.name), str(cell.episodes),
            str(cell.steps), str(cell.interrupted), *terminal_counts, str(cell.outcomes.get("step_limit", 0)),
            _number(cell.careful_next_to_terminal), result.method, _number(result.beta),
            result.interval_kind or "", _number(result.confidence) if result.interval_kind == "confidence" else "",
            *rewards, str(data.left_out.get(cell.participant, 0)) if cell.participant != POOLED else "",
            text_cell(result.error or "; ".join(result.notes)),
        ])
    return columns, rows


def _number(value: float | None) -> str:
    """A number for the CSV: empty for None, else up to 6 significant digits."""
    return "" if value is None or not np.isfinite(value) else f"{float(value):.6g}"
