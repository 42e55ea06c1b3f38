"""`careful check`'s computation: how often a fit's intervals hold the truth, on the user's own design.

Each source of datasets (the fit's own model of play, with its fitted rewards and player; then each rival
person-like player, playing the world's own rewards) plays `datasets` datasets of the recordings' size (one
episode from each recorded start); each dataset is fitted with the user's `FitOptions` (intervals on), and
its intervals are compared with the reward it was simulated with, expressed in the fit's unknowns and unit
(`FitResult.true_theta`: a fit relative to G compares the world's rewards divided by G's; a ``move``
unknown compares a move's cost). Per symbol: with ``tie`` its one unknown; per cell, a symbol is covered in
a dataset when every one of its cells' intervals holds its truth.

A dataset's fit is a call of its own (`fit_dataset`) with its own random stream, so the tally is the same on
one process, a pool or a Dask cluster (`irl_core.support.executor`).
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.stats import binom

from irl_core.coverage.calibrate import learn_scales
from irl_core.coverage.simulate import (
    dataset_rng,
    fitted_policy,
    own_player_name,
    recorded_starts,
    rival_chooser,
    simulate_dataset,
)
from irl_core.errors import FitError
from irl_core.irl.fitting import fit
from irl_core.irl.options import FitOptions
from irl_core.irl.result import FitResult
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.executor import Executor, run_calls
from irl_core.worlds.mdp import MDP

DEFAULT_DATASETS = 50
CSV_COLUMNS = ("player", "rival", "symbol", "datasets", "covered", "coverage", "median_width", "median_error")
# The band a coverage must lie in to be called nominal: the central 95% of Binomial(datasets, confidence).
BAND = 0.95
# An interval holds a truth this close outside it (relative to rmax): solver dust at an end, as `at_bound`.
HOLD_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Work:
    """What every dataset's call needs (sent once per worker): the recorded world's MDP (rivals play in it and
    every refit reads it), the fit's MDP and player policy (its own datasets), the recorded starts, the
    options to refit with, the seed and the sources (None: the fit's own model; else a rival's kind)."""

    recorded_mdp: MDP
    own_mdp: MDP
    own_policy: np.ndarray
    starts: np.ndarray
    options: FitOptions
    seed: int
    sources: tuple[str | None, ...]


@dataclass(frozen=True)
class DatasetFit:
    """One dataset's refit: its unknowns theta (k,) and intervals (k, 2), or why it has none (`problem`)."""

    theta: np.ndarray | None
    intervals: np.ndarray | None
    problem: str | None = None


def fit_dataset(work: Work, source: int, dataset: int) -> DatasetFit:
    """Simulate dataset `dataset` of `work.sources[source]` and fit it as the recordings were fitted."""
    rng = dataset_rng(work.seed, source, dataset)
    kind = work.sources[source]
    if kind is None:
        demos = simulate_dataset(work.own_mdp, work.own_policy, work.starts, rng, recorded_mdp=work.recorded_mdp)
    else:
        demos = simulate_dataset(work.recorded_mdp, rival_chooser(work.recorded_mdp, kind), work.starts, rng,
                                 recorded_mdp=work.recorded_mdp)
    try:
        result = fit(demos, work.options, workers=1)
    except FitError as exc:
        return DatasetFit(None, None, f"the fit failed ({getattr(exc, 'code', None) or type(exc).__name__})")
    if result.intervals is None:
        return DatasetFit(np.asarray(result.theta), None, "no intervals")
    return DatasetFit(np.asarray(result.theta), np.asarray(result.intervals, dtype=float))


@dataclass(frozen=True)
class CoverageRow:
    """One row of check.csv: how often `symbol`'s intervals held the truth over a source's datasets."""

    player: str
    rival: bool
    symbol: str
    datasets: int
    covered: int
    median_width: float
    median_error: float

    @property
    def coverage(self) -> float:
        return self.covered / self.datasets if self.datasets else float("nan")

    def cells(self) -> list[str]:
        """The row as CSV cells (numbers; NaN as an empty cell)."""
        return [self.player, "true" if self.rival else "false", self.symbol, str(self.datasets), str(self.covered),
                _number(self.coverage, 4), _number(self.median_width, 6), _number(self.median_error, 6)]


def _number(value: float, figures: int) -> str:
    return "" if not np.isfinite(value) else f"{value:.{figures}g}"


def tally(player: str, *, rival: bool, symbols: tuple[str, ...], truth: np.ndarray, fits: list[DatasetFit],
          rmax: float) -> list[CoverageRow]:
    """A row per symbol (in the order of the unknowns) over the datasets whose fit has intervals: covered when
    every unknown of the symbol holds its `truth` (k,); the median width and median error (fitted minus
    truth) over its unknowns in every such dataset. A symbol whose truth is not finite counts no dataset."""
    usable = [f for f in fits if f.intervals is not None and f.theta is not None]
    tolerance = HOLD_TOLERANCE * rmax
    rows = []
    for symbol in dict.fromkeys(symbols):
        columns = [j for j, s in enumerate(symbols) if s == symbol]
        if not np.isfinite(truth[columns]).all() or not usable:
            rows.append(CoverageRow(player, rival, symbol, 0, 0, float("nan"), float("nan")))
            continue
        lows = np.array([f.intervals[columns, 0] for f in usable])  # type: ignore[index]
        highs = np.array([f.intervals[columns, 1] for f in usable])  # type: ignore[index]
        points = np.array([f.theta[columns] for f in usable])  # type: ignore[index]
        held = (lows - tolerance <= truth[columns]) & (truth[columns] <= highs + tolerance)
        rows.append(CoverageRow(player, rival, symbol, len(usable), int(held.all(axis=1).sum()),
                                float(np.median(highs - lows)), float(np.median(points - truth[columns]))))
    return rows


def coverage_band(datasets: int, confidence: float) -> tuple[int, int]:
    """The central `BAND` of Binomial(datasets, confidence): the counts of covered datasets called nominal."""
    tail = (1 - BAND) / 2
    return int(binom.ppf(tail, datasets, confidence)), int(binom.ppf(1 - tail, datasets, confidence))


def verdict(rows: list[CoverageRow], confidence: float) -> str:
    """``nominal`` when every symbol's count lies in its `coverage_band`; else ``under-covering: G, C`` (the
    symbols below it), or, none below, ``over-covering: ...`` (wider than the level asks)."""
    below, above = [], []
    for row in rows:
        if not row.datasets:
            continue
        low, high = coverage_band(row.datasets, confidence)
        if row.covered < low:
            below.append(row.symbol)
        elif row.covered > high:
            above.append(row.symbol)
    if below:
        return "under-covering: " + ", ".join(below)
    return "over-covering: " + ", ".join(above) if above else "nominal"


@dataclass(frozen=True)
class CheckResult:
    """The coverage rows, a verdict per player (own model first), why some datasets have no intervals, and the
    scales that would bring every player's intervals to the level (`irl_core.coverage.calibrate`: symbol -> w,
    None where no scale does)."""

    rows: list[CoverageRow]
    verdicts: dict[str, str]
    problems: dict[str, Counter]
    confidence: float
    datasets: int
    scales: dict[str, float | None] = dataclasses.field(default_factory=dict)

    def csv_rows(self) -> list[list[str]]:
        return [row.cells() for row in self.rows]


def run_check(result: FitResult, recorded: Demonstrations, *, rivals: tuple[str, ...], datasets: int = DEFAULT_DATASETS,
              seed: int = 0, executor: Executor | None = None, workers: int = 1,
              progress: Callable[[int, int], None] | None = None) -> CheckResult:
    """The coverage of `result`'s intervals: `datasets` datasets from its own model and from each of `rivals`,
    each of `recorded`'s size, refitted with its options (intervals on), on `executor` (else a local pool of
    `workers`). `progress(done, total)` as refits come back."""
    if datasets < 1:
        raise ValueError(f"datasets must be at least 1, not {datasets}")
    options = dataclasses.replace(result.options, intervals=True)
    sources: tuple[str | None, ...] = (None, *rivals)
    work = Work(recorded_mdp=recorded.mdp, own_mdp=result.mdp, own_policy=fitted_policy(result),
                starts=recorded_starts(recorded), options=options, seed=seed, sources=sources)
    calls = [(source, dataset) for source in range(len(sources)) for dataset in range(datasets)]
    fits: list[DatasetFit | None] = [None] * len(calls)
    done = 0

    def keep(i: int, fitted: DatasetFit) -> None:
        nonlocal done
        fits[i] = fitted
        done += 1
        if progress is not None:
            progress(done, len(calls))

    if executor is None:
        run_calls(fit_dataset, calls, on_result=keep, shared=(work,), workers=workers)
    else:
        executor.run(fit_dataset, calls, on_result=keep, shared=(work,))
    symbols = result.unknowns.symbols
    truths = {None: np.asarray(result.theta, dtype=float)}
    rows: list[CoverageRow] = []
    verdicts: dict[str, str] = {}
    problems: dict[str, Counter] = {}
    learned: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for source, kind in enumerate(sources):
        name = own_player_name(result) if kind is None else kind
        these = [f for f in fits[source * datasets:(source + 1) * datasets] if f is not None]
        truth = truths[None] if kind is None else np.asarray(result.true_theta(), dtype=float)
        mine = tally(name, rival=kind is not None, symbols=symbols, truth=truth, fits=these, rmax=options.rmax)
        rows += mine
        verdicts[name] = verdict(mine, options.confidence)
        problems[name] = Counter(f.problem for f in these if f.problem is not None)
        usable = [f for f in these if f.intervals is not None and f.theta is not None]
        learned.append((np.array([f.theta for f in usable]).reshape(len(usable), len(symbols)),
                        np.array([f.intervals for f in usable]).reshape(len(usable), len(symbols), 2), truth))
    scales = learn_scales(learned, symbols, confidence=options.confidence, tolerance=HOLD_TOLERANCE * options.rmax)
    return CheckResult(rows, verdicts, problems, options.confidence, datasets, scales)
