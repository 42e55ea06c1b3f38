"""A study report's fits: every participant's, each world's pool, and the participants marked against it.

Each world's pool is first fitted as one (a point fit): where it chooses a model of the player, its
participants are fitted with that model, so that one choice, made on the most data, reads them all;
where it cannot tell whether the player plans for the hand (a rival planning model), each participant
is also fitted with the rival. The study's exclusions (`irl_core.studies.study.Exclusions`) then
leave participants out of the pool, and the pool is made by its model (`POOL_MODELS`):

==============  ======================================================================================
``population``  (the default) each participant with their own player; the pooled row is the population
                of participants, a random-effects pool of their fits (`irl_core.studies.population`),
                with outliers and influence from the participants' fits alone
``shared``      one likelihood for everyone's episodes, rewards *and* player shared; intervals resample
                participants, then episodes; influence from the pool refitted without each participant
==============  ======================================================================================

The fits run on one executor (`run_fits`: this machine's process pool, or a Dask cluster).
"""

from __future__ import annotations

import dataclasses
import os
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from irl_core.errors import ClusterLost
from irl_core.irl import FitError, FitOptions, Note, fit
from irl_core.irl.choices import DEFAULT_POOL_MODEL, player_model
from irl_core.irl.choices import pool_model as pool_model_named
from irl_core.studies.population import pool_participants
from irl_core.studies.report_cells import POOLED, Cell, StudyData, leave_out, without_participants
from irl_core.studies.study import Exclusions
from irl_core.support.executor import Executor, LocalPool
from irl_core.support.safe_text import printable
from irl_core.support.stopping import stop_check

# A population needs this many included participants with a fit.
MIN_POPULATION = 2
# A cluster lost mid-report names this many of the fits it did not do, then counts the rest.
MISSING_NAMED = 8


def report_options(*, resamples: int = 200, seed: int = 0, rmax: float = 5000.0) -> FitOptions:
    """The report's fits: the auto method's choice (docs/answers.md; maxent with beta estimated for a person's noisy play),
    one reward per symbol, with intervals (a bootstrap confidence interval for maxent)."""
    return FitOptions(method="auto", tie=True, intervals=True, resamples=resamples, seed=seed, rmax=rmax)




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
        influence: a shared pool's row: each participant's influence on it, None where not measured.
        fit_check_passed: whether the fitted player reproduces the recordings (None: not checked).
        rival_model, rival_estimate: the rival planning model where the fit could not tell it from the chosen
            one (`FitResult.rival_model`), and the rewards under it (k,).
        outlier: a participant's row in a population pool: whether their fit lies outside where the others
            say a participant's would (`irl_core.studies.population`); None where not measured.
        excluded_why: why the study's exclusions leave this participant out of the pool, None when they do not.
        pool_model: a pool's row: ``population`` or ``shared`` (`POOL_MODELS`).
        spread: a population pool's row: (k,) the standard deviation of participants' rewards.
        prediction: a population pool's row: (k, 2) where a new participant's reward lies.
        outliers, influencers: a population pool's row: the participants marked outlier or influential.
        pooled: a population pool's row: how many participants it pools (the included ones with a fit).
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
    fit_check_passed: bool | None = None
    rival_model: str | None = None
    rival_estimate: np.ndarray | None = None
    outlier: bool | None = None
    excluded_why: str | None = None
    pool_model: str | None = None
    spread: np.ndarray | None = None
    prediction: np.ndarray | None = None
    outliers: tuple[str, ...] = ()
    influencers: tuple[str, ...] = ()
    pooled: int | None = None

    @property
    def influential_participants(self) -> tuple[str, ...]:
        """A pool's row: the participants without whom one of its rewards would leave its interval."""
        if self.pool_model == "population":
            return self.influencers
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
        irl_core.errors.Stopped: `stop()` became true during the fit.
    """
    if cell.demos is None:
        return CellFit(error="no finished main episodes")
    if cell.without is not None or cell.rival:
        options = dataclasses.replace(options, intervals=False)
    if cell.player_model is not None:
        options = dataclasses.replace(options, player_model=player_model(cell.player_model).name)
    try:
        result = fit(cell.demos, options, workers=workers, stop=stop, executor=executor)
    except FitError as exc:
        return CellFit(error=str(exc))
    notes = tuple(result.notes)
    if cell.player_model is not None:  # the report chose it on the world's pool; nobody asked for it
        notes = tuple(Note("player_model", f"player model {cell.player_model}, the one chosen on the pool of every "
                                           f"participant's episodes in this world: {player_model(cell.player_model).summary}")
                      if note.code == "player_model" else note for note in notes)
    return CellFit(method=result.method, beta=result.beta, beta_auto=result.beta_auto,
                   symbols=tuple(result.unknowns.symbols), estimate=result.theta.copy(),
                   intervals=None if result.intervals is None else np.asarray(result.intervals, dtype=float),
                   truth=result.true_theta(), interval_kind=result.interval_kind,
                   confidence=options.confidence, rmax=options.rmax, reward_grid=result.reward_grid,
                   notes=notes, player_model=result.player_model,
                   elapsed_s=result.elapsed_s,
                   fit_check_passed=None if result.fit_check is None else result.fit_check.passed,
                   rival_model=result.rival_model, rival_estimate=result.rival_theta)


def run_fits(cells: list[Cell], options: FitOptions, *, workers: int | None = None,
             progress: Callable[[int, int], None] | None = None, executor: Executor | None = None,
             world_names: Sequence[str] = ()) -> list[CellFit]:
    """Fit every cell, on `executor` (default: a process pool of `workers`, default the cores); results in
    `cells`' order. A cell whose worker died and could not be rerun comes back with the error saying so; a
    cluster lost altogether raises `ClusterLost` naming the cells not fitted (`cell_name`, with `world_names`).

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

    try:
        if len(cells) == 1 or executor.workers == 1 and not executor.remote:
            # One cell at a time (a world's pool, fitted first): its bootstrap takes the cores (or the cluster) instead.
            inside = executor if executor.remote else None
            for k, i in enumerate(order):
                returned(k, fit_cell(cells[i], options, workers=workers or os.cpu_count() or 1, executor=inside))
        else:
            executor.run(_fit_in_worker, [(cells[i], options) for i in order], on_result=returned,
                         on_lost=lambda k, reason: returned(k, CellFit(error=f"not fitted: {reason}")))
    except ClusterLost as exc:
        missing = [cell_name(cell, world_names) for cell, fitted in zip(cells, fits) if fitted is None]
        raise ClusterLost(f"{exc}; not fitted: {', '.join(missing[:MISSING_NAMED])}"
                          + (f" and {len(missing) - MISSING_NAMED} more" if len(missing) > MISSING_NAMED else ""),
                          tuple(i for i, fitted in enumerate(fits) if fitted is None)) from None
    fitted = [fit for fit in fits if fit is not None]
    assert len(fitted) == len(cells), "every cell came back fitted"
    return fitted


def cell_name(cell: Cell, world_names: Sequence[str] = ()) -> str:
    """ "p001 · mud", "pooled · mud", "pooled without p001 · mud" (the world's index, from 1, without its name)."""
    who = cell.participant if cell.without is None else f"{cell.participant} without {cell.without}"
    world = (printable(world_names[cell.world_index], limit=40) if cell.world_index < len(world_names)
             else f"world {cell.world_index + 1}")
    return f"{who}{' (rival model)' if cell.rival else ''} · {world}"


def _fit_in_worker(cell: Cell, options: FitOptions) -> CellFit:
    """`fit_cell` in a worker of `run_in_pool`, stopping when the report is left (Ctrl+C)."""
    return fit_cell(cell, options, stop=stop_check())


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


def fit_report(data: StudyData, options: FitOptions, *, pool_model: str = DEFAULT_POOL_MODEL,
               exclusions: Exclusions | None = None, workers: int | None = None,
               progress: Callable[[int, int], None] | None = None, executor: Executor | None = None) -> list[CellFit]:
    """Every cell's fit (in `data.cells`' order): participants marked against their world's pool, excluded ones
    named, each pooled row made by `pool_model` (see the module).

    Args:
        exclusions: who is left out of the pools (default the study file's ``[exclusions]``; ``Exclusions()``
            leaves nobody out).
        progress: called as progress(fits done, fits known so far) as each comes back.
        executor: where the fits run (`irl_core.support.executor`: a Dask cluster); default this machine's
            process pool of `workers`. The numbers are the same either way.
    """
    pool_model_named(pool_model)
    exclusions = data.study.study.exclusions if exclusions is None else exclusions
    tally = _Tally(progress, tuple(world.name for world in data.study.grid_worlds))
    pools = {i: cell for i, cell in enumerate(data.cells) if cell.participant == POOLED}
    choices = dict(zip(pools, tally.run([dataclasses.replace(c, without=None) for c in pools.values()],
                                        dataclasses.replace(options, intervals=False), workers, executor)))
    model = {cell.world_index: choices[i].player_model for i, cell in pools.items()}
    rival = {cell.world_index: choices[i].rival_model for i, cell in pools.items()
             if pool_model == "population" and choices[i].rival_model}
    mine = [i for i, cell in enumerate(data.cells) if cell.participant != POOLED]
    rivals = [i for i in mine if data.cells[i].world_index in rival and data.cells[i].demos is not None]
    later = [dataclasses.replace(data.cells[i], player_model=model[data.cells[i].world_index]) for i in mine]
    later += [dataclasses.replace(data.cells[i], player_model=rival[data.cells[i].world_index], rival=True)
              for i in rivals]
    fitted = tally.run(later, options, workers, executor)
    fits: list[CellFit] = [CellFit()] * len(data.cells)
    for i, result in zip(mine, fitted):
        fits[i] = dataclasses.replace(result, excluded_why=excluded_why(data.cells[i], result, exclusions))
    for i, result in zip(rivals, fitted[len(mine):]):
        if not result.error:
            fits[i] = dataclasses.replace(fits[i], rival_model=result.player_model, rival_estimate=result.estimate)
    for i, cell in pools.items():
        members = [(j, data.cells[j]) for j in mine if data.cells[j].world_index == cell.world_index]
        if pool_model == "population":
            fits[i] = population_row(choices[i], members, fits, layout=data.study.grid_worlds[cell.world_index].layout)
        else:
            left_out = {c.participant for j, c in members if fits[j].excluded_why}
            fits[i] = shared_row(without_participants(cell, left_out), options, fits, data, tally, workers, executor)
    return fits


class _Tally:
    """Counts fits across the report's rounds for one progress callback."""

    def __init__(self, progress: Callable[[int, int], None] | None, world_names: tuple[str, ...] = ()) -> None:
        self.progress, self.done, self.total = progress, 0, 0
        self.world_names = world_names

    def run(self, cells: list[Cell], options: FitOptions, workers: int | None, executor: Executor | None
            ) -> list[CellFit]:
        self.total += len(cells)
        offset = self.done

        def counted(done: int, _: int) -> None:
            self.done = offset + done
            if self.progress:
                self.progress(self.done, self.total)

        return run_fits(cells, options, workers=workers, progress=counted, executor=executor,
                        world_names=self.world_names) if cells else []


def excluded_why(cell: Cell, result: CellFit, exclusions: Exclusions) -> str | None:
    """Why `exclusions` leave this participant's cell out of its pool ("fit check failed; 3 main episodes,
    fewer than 8"), or None."""
    why = []
    if exclusions.fit_check_failed and result.fit_check_passed is False:
        why.append("fit check failed")
    if cell.episodes < exclusions.min_main_episodes:
        why.append(f"{cell.episodes} finished main episodes, fewer than {exclusions.min_main_episodes}")
    quit_count = cell.interrupted_outcomes.get("quit", 0)
    played = cell.episodes + cell.interrupted
    if played and quit_count / played > exclusions.max_quit_share:
        why.append(f"quit {quit_count} of {played} main episodes, more than {exclusions.max_quit_share:.0%}")
    return "; ".join(why) or None


def population_row(choice: CellFit, members: list[tuple[int, Cell]], fits: list[CellFit], *, layout: str
                   ) -> CellFit:
    """A world's pooled row as the population of its included participants (`pool_participants`), each
    member's `outlier` and `influential` marks written into `fits` (members: (index in fits, cell)); its
    reward grid holds the population's centre on the cells of each symbol of `layout`."""
    symbols = choice.symbols
    used = [(j, c.participant) for j, c in members
            if not fits[j].excluded_why and not fits[j].error and fits[j].intervals is not None]
    base = dataclasses.replace(choice, pool_model="population", interval_kind="confidence", beta=None,
                               beta_auto=False, fit_check_passed=None, notes=tuple(n for n in choice.notes
                                                            if n.code in ("player_model", "planning_not_identified")))
    if choice.error:
        return base
    if len(used) < MIN_POPULATION:
        counted = {j for j, _ in used}
        left = Counter("excluded" if fits[j].excluded_why else "not fitted" if fits[j].error else "fitted without intervals"
                       for j, _ in members if j not in counted)
        why = "".join(f", {n} {reason}" for reason, n in sorted(left.items()))
        # No centre without the participants' intervals: the row shows none rather than another pool's numbers.
        return CellFit(error=f"a population needs {MIN_POPULATION} or more included participants fitted with "
                             f"intervals; {len(used)} here{why}", player_model=choice.player_model,
                       pool_model="population", notes=base.notes)
    intervals = np.array([[_interval_of(fits[j], s, choice.rmax) for s in symbols] for j, _ in used])
    shift = None
    if choice.rival_model:
        shift = np.array([[_rival_shift(fits[j], s) for s in symbols] for j, _ in used])
    population = pool_participants(intervals, rmax=choice.rmax, confidence=choice.confidence, rival_shift=shift)
    for (j, _), out, moved in zip(used, population.outlier, population.influential):
        fits[j] = dataclasses.replace(fits[j], outlier=bool(out), influential=bool(moved))
    return dataclasses.replace(
        base, estimate=population.centre, intervals=population.intervals, spread=population.spread,
        reward_grid=_centre_grid(choice, population.centre, layout),
        prediction=population.predictions, pooled=len(used),
        outliers=tuple(name for (_, name), out in zip(used, population.outlier) if out),
        influencers=tuple(name for (_, name), moved in zip(used, population.influential) if moved))


def _centre_grid(choice: CellFit, centre: np.ndarray, layout: str) -> np.ndarray | None:
    """(rows, cols) the choice fit's reward grid with each fitted symbol's cells at the population's centre
    (NaN where the population has no centre: every participant bounds it on one side only)."""
    if choice.reward_grid is None:
        return None
    grid = np.array(choice.reward_grid, dtype=float)
    for r, row in enumerate(layout.splitlines()):
        for c, symbol in enumerate(row):
            if symbol in choice.symbols and r < grid.shape[0] and c < grid.shape[1]:
                grid[r, c] = centre[choice.symbols.index(symbol)]
    return grid


def _interval_of(result: CellFit, symbol: str, rmax: float) -> tuple[float, float]:
    """A participant's interval for `symbol`, or the whole range where their fit has no such reward."""
    if symbol not in result.symbols or result.intervals is None:
        return (-rmax, rmax)
    low, high = result.intervals[result.symbols.index(symbol)]
    return (float(low), float(high))


def _rival_shift(result: CellFit, symbol: str) -> float:
    """How far `symbol`'s reward moves under the rival planning model (0 where it was not fitted)."""
    if result.rival_estimate is None or symbol not in result.symbols:
        return 0.0
    j = result.symbols.index(symbol)
    return float(result.rival_estimate[j] - result.estimate[j])


def shared_row(pool: Cell, options: FitOptions, fits: list[CellFit], data: StudyData, tally: _Tally,
               workers: int | None, executor: Executor | None) -> CellFit:
    """A world's pooled row as one fit of its included participants' episodes (the fixed-effect pool), with
    intervals, and each member's influence (the pool refitted without them) written into `fits`."""
    (pooled,) = tally.run([pool], options, workers, executor)
    i = next(j for j, c in enumerate(data.cells) if c.participant == POOLED and c.world_index == pool.world_index)
    fits[i] = dataclasses.replace(pooled, pool_model="shared")
    others = [dataclasses.replace(leave_out(pool, member), player_model=pooled.player_model)
              for member in pool.members] if len(pool.members) > 1 else []
    without = {(c.world_index, c.without): f for c, f in zip(others, tally.run(others, options, workers, executor))}
    fits[:] = with_influence(data, fits, without)
    return fits[i]


def with_influence(data: StudyData, fits: list[CellFit], without: dict[tuple[int, str | None], CellFit]
                   ) -> list[CellFit]:
    """`fits` with each participant's influence on their world's shared pool: `without[(world_index,
    participant)]` is the pool's fit without them; they are influential when any of its rewards lies outside
    the pool's interval for that reward."""
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
