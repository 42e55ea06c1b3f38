"""A study's report (docs/studies.md), as plain data: per participant and pooled fits per world.

`gather` reads every participant folder under the study's ``out`` and keeps each one's
finished main-phase episodes per world (practice never enters a fit; an interrupted episode
is counted, not fitted; see `irl_core.studies.study`). A file that cannot be used is named in
`StudyData.problems` and left out; the participant's other files are still reported.
`fit_report` fits every (participant, world), every world's pool, and every pool without each of
its participants in turn (`run_fits`: one process pool across the cores; each fit's bootstrap
runs inside its worker, ``workers=1``, so the cores are not asked for twice). A pool's interval
resamples participants, then episodes within them (docs/studies-pooling.md), so it covers
differences between people; a participant without whom a pooled reward would leave its interval
is marked influential. `report_rows` is the table the command prints and writes as CSV, and
`pooled_finding` says in a sentence what each world's pooled row shows.
"""

from __future__ import annotations

import dataclasses
import os
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from irl_core.experiment.claims import SYMBOL_WORDS, interval_text, number_text, order_words
from irl_core.irl import FitError, FitOptions, Note, fit
from irl_core.recordings.demonstrations import Demonstrations, Recording
from irl_core.recordings.end_table import EndTable
from irl_core.recordings.step_table import StepTable
from irl_core.recordings.summary import distance_to_terminal, outcome_code
from irl_core.studies.study import (
    POOLED,
    REPORT_FOLDER,
    LoadedStudy,
    StudyError,
    check_participant,
    finished_episodes,
    interrupted_episodes,
    read_participant,
)
from irl_core.support.csv_cells import text_cell
from irl_core.support.executor import Executor, LocalPool
from irl_core.support.stopping import stop_check


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
        outcomes: finished episodes per `irl_core.recordings.summary.outcome_code` (a terminal symbol, or
            ``step_limit``).
        interrupted_outcomes: main episodes with steps that did not finish (not fitted), per
            outcome code (``quit``, or ``unfinished``: no end recorded).
        careful_next_to_terminal: mean carefulness of the steps taken next to a terminal cell
            (one grid step away), or None when there were none.
        participants: how many participants the cell holds (1, or how many have episodes in the pool).
        members: in a pool, the participants whose episodes it holds, in the order of
            ``demos.episode_groups`` (group g is members[g]).
        without: in a pool without one participant (`leave_out`), that participant: its fit is a
            point fit (no interval) that measures their influence on the pool.
        player_model: the model of the player to fit with, where the report has chosen it already
            (the world's pool chooses; its participants and the pools without one of them follow).
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
    members: tuple[str, ...] = ()
    without: str | None = None
    player_model: str | None = None

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
    ids: list[str] = []
    problems: list[str] = []
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
        cells.append(_grouped(dataclasses.replace(pooled, participants=contributing),
                              [cell for cell in cells if cell.world_index == world_index]))
    # World by world: its participants in name order, then its pool.
    cells.sort(key=lambda cell: (cell.world_index, cell.participant == POOLED))
    return StudyData(study=study, participants=tuple(ids), cells=tuple(cells), problems=tuple(problems),
                     left_out=left_out, folders_left_out=folders_left_out)


def _grouped(pool: Cell, mine: list[Cell]) -> Cell:
    """The pool with each of its episodes' participant (`mine`: the world's cells in the pool's order,
    whose episodes the pool's rows hold one participant after another)."""
    if pool.demos is None or pool.demos.by_episode is None:
        return pool
    members = [(cell.participant, cell.demos.by_episode.shape[0]) for cell in mine
               if cell.demos is not None and cell.demos.by_episode is not None]
    rows = [episodes for _, episodes in members]
    assert sum(rows) == pool.demos.by_episode.shape[0], "a pool's episodes are its participants' in order"
    groups = np.repeat(np.arange(len(members)), rows)
    return dataclasses.replace(pool, demos=dataclasses.replace(pool.demos, episode_groups=groups),
                               members=tuple(participant for participant, _ in members))


def leave_out(pool: Cell, participant: str) -> Cell:
    """The pool without `participant`'s episodes (its outcome counts are the pool's: only the fit is used)."""
    demos = pool.demos
    assert demos is not None and demos.by_episode is not None and demos.episode_groups is not None
    keep = demos.episode_groups != pool.members.index(participant)
    by_episode = demos.by_episode[keep]
    counts = np.asarray(by_episode.sum(axis=0)).reshape(demos.counts.shape)
    # files stays the pool's: a leave-one-out fit is never written out.
    facts = None if demos.episode_facts is None else demos.episode_facts.rows(keep)
    demos = dataclasses.replace(demos, counts=counts, episodes=int(keep.sum()), steps=int(counts.sum()),
                                by_episode=by_episode, episode_groups=None, episode_facts=facts)
    return dataclasses.replace(pool, demos=demos, episodes=demos.episodes, steps=demos.steps,
                               members=tuple(m for m in pool.members if m != participant), without=participant)


def influence_cells(data: StudyData) -> list[Cell]:
    """Every pool of two or more participants without each of them in turn."""
    return [leave_out(cell, member) for cell in data.cells if cell.participant == POOLED and len(cell.members) > 1
            for member in cell.members]


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
        influential: a participant's row: whether without them a pooled reward would leave its
            interval; None where not measured (a pool of one, a pool or a fit without them that failed).
        influence: a pool's row: each participant's influence on it, None where not measured.
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
    notes: tuple[Note, ...] = ()
    player_model: str | None = None
    elapsed_s: float = 0.0
    error: str | None = None
    influential: bool | None = None
    influence: tuple[Influence, ...] | None = None

    @property
    def influential_participants(self) -> tuple[str, ...]:
        """A pool's row: the participants without whom one of its rewards would leave its interval."""
        return tuple(i.participant for i in self.influence or () if i.outside)


@dataclass(frozen=True)
class Influence:
    """One participant's influence on a pool: the pooled fit without them.

    Attributes:
        without: (symbol, the pooled reward without them) per symbol of the pool.
        outside: the symbols whose reward without them lies outside the pool's interval.
        shift: the largest move of a reward without them, in widths of its pooled interval.
        most: the symbol that moves by `shift`.
    """

    participant: str
    without: tuple[tuple[str, float], ...]
    outside: tuple[str, ...]
    shift: float
    most: str


def fit_cell(cell: Cell, options: FitOptions, *, stop: Callable[[], bool] | None = None,
             workers: int = 1, executor: Executor | None = None) -> CellFit:
    """Fit one cell (its bootstrap on `workers` processes; a pool without a participant, `Cell.without`, is
    fitted without intervals); a cell without steps or a failed fit gives an error.

    Raises:
        irl_core.support.stopping.Stopped: `stop()` became true during the fit.
    """
    if cell.demos is None:
        return CellFit(error="no finished main episodes")
    if cell.without is not None:
        options = dataclasses.replace(options, intervals=False)
    if cell.player_model is not None:
        options = dataclasses.replace(options, player_model=cell.player_model)
    try:
        result = fit(cell.demos, options, workers=workers, stop=stop, executor=executor)
    except FitError as exc:
        return CellFit(error=str(exc))
    return CellFit(method=result.method, beta=result.beta, beta_auto=result.beta_auto,
                   symbols=tuple(result.unknowns.symbols), estimate=result.theta.copy(),
                   intervals=None if result.intervals is None else np.asarray(result.intervals, dtype=float),
                   truth=result.unknowns.true_theta(result.mdp), interval_kind=result.interval_kind,
                   confidence=options.confidence, rmax=options.rmax, reward_grid=result.reward_grid,
                   notes=tuple(result.notes), player_model=result.player_model,
                   elapsed_s=result.elapsed_s)


def run_fits(cells: list[Cell], options: FitOptions, *, workers: int | None = None,
             progress: Callable[[int, int], None] | None = None, executor: Executor | None = None) -> list[CellFit]:
    """Fit every cell, on `executor` (default: a process pool of `workers`, default the cores); results in
    `cells`' order. A cell whose worker died and could not be rerun comes back with the error saying so.

    The biggest cells (the pools) are sent first, so the last fits to finish are small ones.
    """
    fits: list[CellFit | None] = [None] * len(cells)
    order = sorted(range(len(cells)), key=lambda i: -cells[i].steps)
    if executor is None:
        executor = LocalPool(max(1, min(workers or os.cpu_count() or 1, len(cells))))
    done = 0

    def returned(k: int, fitted: CellFit) -> None:
        nonlocal done
        fits[order[k]] = fitted
        done += 1
        if progress:
            progress(done, len(cells))

    if len(cells) == 1 or executor.workers == 1 and not executor.remote:
        # One cell at a time (a world's pool, fitted first): its bootstrap takes the cores (or the cluster) instead.
        inside = executor if executor.remote else None
        for k, i in enumerate(order):
            returned(k, fit_cell(cells[i], options, workers=workers or os.cpu_count() or 1, executor=inside))
    else:
        executor.run(_fit_in_worker, [(cells[i], options) for i in order], on_result=returned,
                     on_lost=lambda k, reason: returned(k, CellFit(error=f"not fitted: {reason}")))
    fitted = [fit for fit in fits if fit is not None]
    assert len(fitted) == len(cells), "every cell came back fitted"
    return fitted


def _fit_in_worker(cell: Cell, options: FitOptions) -> CellFit:
    """`fit_cell` in a worker of `run_in_pool`, stopping when the report is left (Ctrl+C)."""
    return fit_cell(cell, options, stop=stop_check())


def fit_report(data: StudyData, options: FitOptions, *, workers: int | None = None,
               progress: Callable[[int, int], None] | None = None, executor: Executor | None = None) -> list[CellFit]:
    """Every cell's fit (in `data.cells`' order), with each pool's participants marked by their influence.

    Each world's pool is fitted first: where it chooses a model of the player (`FitOptions.player_model`
    auto), its participants and the pools without each of them (`influence_cells`, point fits) are then
    fitted with that model, so that their rewards are read through one model and the choice by held-out
    episodes is made once per world, on the most data.

    Args:
        progress: called as progress(fits done, fits) as each comes back.
        executor: where the fits run (`irl_core.support.executor`: a Dask cluster); default this machine's
            process pool of `workers`. The numbers are the same either way.
    """
    without = influence_cells(data)
    cells = [*data.cells, *without]
    first = [i for i, cell in enumerate(cells) if cell.participant == POOLED and cell.without is None]
    rest = [i for i in range(len(cells)) if i not in first]

    def counted(offset: int) -> Callable[[int, int], None] | None:
        return None if progress is None else (lambda done, _: progress(offset + done, len(cells)))

    fitted: dict[int, CellFit] = {}
    chosen: dict[int, str | None] = {}
    for i, fit_of_pool in zip(first, run_fits([cells[i] for i in first], options, workers=workers,
                                              progress=counted(0), executor=executor)):
        fitted[i] = fit_of_pool
        chosen[cells[i].world_index] = fit_of_pool.player_model
    later = [dataclasses.replace(cells[i], player_model=chosen.get(cells[i].world_index)) for i in rest]
    fitted.update(zip(rest, run_fits(later, options, workers=workers, progress=counted(len(first)),
                                          executor=executor)))
    fits = [fitted[i] for i in range(len(cells))]
    return with_influence(data, fits[: len(data.cells)], dict(zip(((c.world_index, c.without) for c in without),
                                                                  fits[len(data.cells):])))


def with_influence(data: StudyData, fits: list[CellFit], without: dict[tuple[int, str | None], CellFit]
                   ) -> list[CellFit]:
    """`fits` with each participant's influence on their world's pool: `without[(world_index, participant)]`
    is the pool's fit without them; they are influential when any of its rewards lies outside the
    pool's interval for that reward."""
    pools = {cell.world_index: i for i, cell in enumerate(data.cells) if cell.participant == POOLED}
    measured: dict[int, list[Influence]] = {}
    out = list(fits)
    for i, cell in enumerate(data.cells):
        pooled = fits[pools[cell.world_index]]
        other = without.get((cell.world_index, cell.participant))
        if cell.participant == POOLED or other is None or other.error or pooled.error or pooled.intervals is None:
            continue
        influence = influence_of(cell.participant, pooled, other)
        out[i] = dataclasses.replace(fits[i], influential=bool(influence.outside))
        measured.setdefault(cell.world_index, []).append(influence)
    for world_index, influences in measured.items():
        out[pools[world_index]] = dataclasses.replace(fits[pools[world_index]], influence=tuple(influences))
    return out


def influence_of(participant: str, pooled: CellFit, other: CellFit) -> Influence:
    """How `other` (the pool's fit without `participant`) lies against `pooled`'s estimates and intervals."""
    assert pooled.intervals is not None
    values, outside, shift, most = [], [], -1.0, ""
    for j, symbol in enumerate(pooled.symbols):
        if symbol not in other.symbols:
            continue
        value = float(other.estimate[other.symbols.index(symbol)])
        low, high = pooled.intervals[j]
        slack = 1e-9 * max(1.0, abs(low), abs(high))
        values.append((symbol, value))
        if not low - slack <= value <= high + slack:
            outside.append(symbol)
        moved = abs(value - pooled.estimate[j]) / max(high - low, slack)
        if moved > shift:
            shift, most = float(moved), symbol
    return Influence(participant, tuple(values), tuple(outside), max(shift, 0.0), most)


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
    fitted symbol, files_left_out, note, influential (a participant's row: ``true`` or ``false``;
    a pool's: the influential participants, space-separated, or ``none``), finding (a pool's row:
    `pooled_finding`). Empty where a value does not apply.
    """
    study = data.study
    terminals = sorted({t for w in study.worlds for t in w.terminal})
    symbols = report_symbols(study, fits)
    columns = ["study", "participant", "world_index", "world", "episodes", "steps", "interrupted",
               *(f"ended_{t}" for t in terminals), "step_limit", "careful_next_to_terminal", "method", "beta",
               "interval_kind", "confidence",
               *(f"reward_{s}{end}" for s in symbols for end in ("", "_low", "_high")), "files_left_out", "note",
               "influential", "finding"]
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
            text_cell(result.error or "; ".join(str(note) for note in result.notes)),
            _influence_cell(result),
            text_cell(pooled_finding(data, cell, result)) if cell.participant == POOLED else "",
        ])
    return columns, rows


def _influence_cell(result: CellFit) -> str:
    if result.influential is not None:
        return "true" if result.influential else "false"
    if result.influence is not None:
        return " ".join(result.influential_participants) or "none"
    return ""


def pooled_finding(data: StudyData, cell: Cell, result: CellFit) -> str:
    """What a world's pooled row shows, in a sentence from its numbers: whether the pooled interval of
    the worst hazard (a terminal symbol with the most negative reward) lies below the nuisance's
    (a non-terminal one with a negative reward), as carefulness should make it; which intervals miss
    the world's rewards; who is influential.

    "mud: the pooled cliff interval [-1420, -869] lies below the mud's [-52, -24]: carefulness
    separates catastrophe from nuisance; every interval covers the world's reward; no participant
    alone moves a pooled reward out of its interval."
    """
    world = data.study.worlds[cell.world_index]
    if result.error:
        return f"{world.name}: no pooled fit ({result.error})."
    if result.intervals is None:
        return f"{world.name}: no pooled interval (see the note), so nothing to compare."
    truth = dict(zip(result.symbols, result.truth))
    interval = {s: (float(low), float(high)) for s, (low, high) in zip(result.symbols, result.intervals)}
    hazards = sorted((truth[s], s) for s in result.symbols if s in world.terminal and truth[s] < 0)
    nuisances = sorted((truth[s], s) for s in result.symbols if s not in world.terminal and truth[s] < 0)
    parts = []
    if hazards and nuisances:
        hazard, nuisance = hazards[0][1], nuisances[0][1]
        h, n = _word(hazard), _word(nuisance)
        order = order_words(interval[hazard], interval[nuisance])
        said = {"below": "lies below", "above": "lies above", "overlaps": "overlaps"}[order]
        verdict = {"below": "carefulness separates catastrophe from nuisance" if world.levels > 1 else
                            "they lie apart, though with one level of carefulness it is the model's assumptions, "
                            "not carefulness, that separate them",
                   "above": f"the {n} comes out worse than the {h}",
                   "overlaps": "these participants' play does not separate catastrophe from nuisance"}[order]
        parts.append(f"the pooled {h} interval {interval_text(interval[hazard])} {said} the {n}'s "
                     f"{interval_text(interval[nuisance])}: {verdict}")
    elif hazards:
        parts.append(_signs(hazards[0][1], interval, [s for s in result.symbols if truth[s] > 0]))
    missed = [f"the {_word(s)}'s interval misses the world's {truth[s]:g}" for s in sorted(result.symbols, key=truth.__getitem__)
              if not interval[s][0] <= truth[s] <= interval[s][1]]
    parts.append("; ".join(missed) if missed else "every interval covers the world's reward")
    if result.influence:
        parts.append(_influence_words(result))
    return f"{world.name}: " + "; ".join(parts) + "."


def _signs(hazard: str, interval: dict[str, tuple[float, float]], goals: list[str]) -> str:
    """Whether the hazard's pooled interval lies below 0 and the goals' above, in a world without a nuisance."""
    h = _word(hazard)
    below = interval[hazard][1] < 0
    text = f"the pooled {h} interval {interval_text(interval[hazard])} {'lies' if below else 'does not lie'} below 0"
    for goal in goals:
        above = interval[goal][0] > 0
        text += (f"{' and' if above == below else ', but'} the {_word(goal)}'s {interval_text(interval[goal])} "
                 f"{'lies' if above else 'does not lie'} above it")
    return text


def _word(symbol: str) -> str:
    return SYMBOL_WORDS.get(symbol, repr(symbol))


def _influence_words(pooled: CellFit) -> str:
    """"without p07 the cliff -361, outside the pooled interval: ...", or that no one alone moves the pool
    and who moves it most."""
    assert pooled.influence
    moved = [i for i in pooled.influence if i.outside]
    if not moved:
        most = max(pooled.influence, key=lambda i: i.shift)
        if not most.most:
            return "no participant alone moves a pooled reward out of its interval"
        value = dict(most.without)[most.most]
        pooled_value = pooled.estimate[pooled.symbols.index(most.most)]
        return (f"no participant alone moves a pooled reward out of its interval (the most: without "
                f"{most.participant} the {_word(most.most)} {number_text(value)} against {number_text(pooled_value)})")
    said = []
    for influence in moved:
        values = " and ".join(f"the {_word(symbol)} {number_text(value)}" for symbol, value in influence.without
                              if symbol in influence.outside)
        said.append(f"without {influence.participant} {values}")
    several = len(moved) > 1 or len(moved[0].outside) > 1
    return (f"{'; '.join(said)}, outside the pooled interval{'s' if several else ''}: "
            f"{'this participant moves' if len(said) == 1 else 'each of these participants moves'} the pool alone")


def _number(value: float | None) -> str:
    """A number for the CSV: empty for None, else up to 6 significant digits."""
    return "" if value is None or not np.isfinite(value) else f"{float(value):.6g}"
