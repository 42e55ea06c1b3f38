"""Confidence intervals for maxent and loss by resampling whole episodes (docs/answers.md).

The demonstrations are E episodes. A resample draws E episodes with replacement, so its
counts are w @ by_episode for multiplicities w ~ Multinomial(E, 1/E); each resample is
refitted, warm-started from the full-data fit, and the spread of the refits is the sampling
noise of the estimate. Episodes, not steps, are resampled because the steps of one episode
are not independent (a careless start is followed by a rescue).

Two intervals come from the same refits (theta_hat the full-data fit, q the quantiles of
the refits at (1 - confidence)/2 and (1 + confidence)/2):

==============  =====================================================================
``percentile``  [q_low, q_high]
``basic``       [2 theta_hat - q_high, 2 theta_hat - q_low], which corrects a bias of the
                refits around theta_hat by reflecting it
==============  =====================================================================

`bench/bench_calibration.py` measures how often each contains the truth; `fit` uses the
better calibrated one (`INTERVAL_VARIANT`, chosen from that measurement: see the README).

Resamples run in parallel across cores in `irl_core.support.pool.run_in_pool` (its workers die with this
process), or on a Dask cluster (`irl_core.support.executor`). The multiplicities are drawn in the parent from
`seed`, so the same seed gives the same interval whatever the number of workers. A fit told to
stop tells its workers too (`stopping.stop_when` on their side): queued resamples are dropped
and running maxent refits stop at their next soft Bellman solve.

Episodes that come in groups (a study's pool: each participant's episodes) are resampled at two
levels (`two_level_weights`): the groups with replacement, then within each group drawn its
episodes with replacement, so the interval covers differences between the groups too.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from irl_core.irl.choices import RESAMPLED
from irl_core.irl.loss.solve import fit_loss
from irl_core.irl.lp.solve import Progress
from irl_core.irl.maxent import fit_maxent
from irl_core.irl.qmap import Unknowns, build_qmap
from irl_core.support.executor import Executor, LocalPool
from irl_core.support.stopping import Stopped
from irl_core.worlds.mdp import MDP

VARIANTS = ("percentile", "basic")
INTERVAL_VARIANT = "percentile"
# A resample's maxent refit, over variables scaled to unit curvature (`maxent.curvature_scale`),
# stops at this projected gradient: its error is then far below the resampling noise.
RESAMPLE_GRADIENT_TOLERANCE = 1e-5
RESAMPLE_VALUE_TOLERANCE = 1e-12


class Refitter(Protocol):
    """What the bootstrap refits with: a picklable callable from a resample's counts (S, A) and its number to its
    p parameters (`Refit` for maxent and loss, `people.PlayerRefit` for a model of people, which also resamples
    a study's calibration trials, drawn by the resample's number so that any worker draws the same)."""

    @property
    def mdp(self) -> MDP: ...

    @property
    def unknowns(self) -> Unknowns: ...

    @property
    def size(self) -> int: ...

    def __call__(self, counts: np.ndarray, *, resample: int = 0) -> np.ndarray: ...


@dataclass(frozen=True, eq=False)
class Refit:
    """How to refit one resample's counts (S, A): the method (one in `REFITS`;
    any other raises ValueError here), its settings, the warm start (theta, beta) and, for maxent,
    the variables' scale at the full-data fit."""

    mdp: MDP
    unknowns: Unknowns
    method: str
    rmax: float
    lam: float
    beta: float | str
    start: tuple[np.ndarray, float]
    scale: np.ndarray | None = None
    start_V: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.method not in RESAMPLED:
            raise ValueError(f"no bootstrap refit for method {self.method!r}: one of {', '.join(RESAMPLED)}")

    @property
    def size(self) -> int:
        """p: the unknowns, and beta when it is estimated."""
        return self.unknowns.k + int(self.beta == "auto")

    def __call__(self, counts: np.ndarray, *, resample: int = 0) -> np.ndarray:
        """(p,) the unknowns fitted to `counts` (S, A), with beta appended when it is estimated (`resample`: its
        number, which these methods do not need)."""
        return REFITS[self.method](self, counts)


def maxent_refit(refit: Refit, counts: np.ndarray) -> np.ndarray:
    solution = fit_maxent(refit.mdp, refit.unknowns, counts, beta=refit.beta, rmax=refit.rmax, start=refit.start,
                          start_V=refit.start_V, scale=refit.scale, gradient_tolerance=RESAMPLE_GRADIENT_TOLERANCE,
                          value_tolerance=RESAMPLE_VALUE_TOLERANCE)
    return np.append(solution.theta, solution.beta) if refit.beta == "auto" else solution.theta


def loss_refit(refit: Refit, counts: np.ndarray) -> np.ndarray:
    totals = counts.sum(axis=1, keepdims=True)
    frequencies = np.divide(counts, totals, out=np.zeros_like(counts), where=totals > 0)
    solution = fit_loss(build_qmap(refit.mdp, refit.unknowns), frequencies, rmax=refit.rmax, lam=refit.lam)
    return np.asarray(solution.x[: refit.unknowns.k], dtype=float)


# Each resampled method's refit under its registry name (a test holds the keys equal to `choices.RESAMPLED`).
REFITS = {"maxent": maxent_refit, "loss": loss_refit}


@dataclass(frozen=True)
class BootstrapResult:
    """The refits of every resample and the intervals they give.

    Attributes:
        estimates: (resamples, p) each resample's refit (p = k, or k + 1 with beta last).
        intervals: (p, 2) [low, high] per parameter at `confidence`.
        confidence: the confidence level.
        variant: ``percentile`` or ``basic``.
        failed: resamples whose refit raised (left out of the intervals; when all did, every interval is NaN).
    """

    estimates: np.ndarray
    intervals: np.ndarray
    confidence: float
    variant: str
    failed: int


def resample_weights(episodes: int, resamples: int, seed: int) -> np.ndarray:
    """(resamples, episodes) multiplicities of each episode in each resample (rows sum to `episodes`)."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(episodes, np.full(episodes, 1.0 / episodes), size=resamples).astype(float)


def two_level_weights(groups: np.ndarray, resamples: int, seed: int) -> np.ndarray:
    """(resamples, E) multiplicities of each episode when its group (`groups`, (E,) ints) is resampled first.

    Each resample draws G groups with replacement (G the groups present), then, for every time a group
    was drawn, as many of its episodes as it has, with replacement. A group drawn m times holding n
    episodes thus contributes m * n episodes, Multinomial(m * n, 1/n) over its own (the sum of m
    independent draws); a group not drawn contributes none.
    """
    labels, members = np.unique(np.asarray(groups), return_inverse=True)
    rng = np.random.default_rng(seed)
    drawn = rng.multinomial(labels.size, np.full(labels.size, 1.0 / labels.size), size=resamples)
    weights = np.zeros((resamples, members.size))
    for g in range(labels.size):
        mine = np.flatnonzero(members == g)
        weights[:, mine] = rng.multinomial(drawn[:, g] * mine.size, np.full(mine.size, 1.0 / mine.size))
    return weights


def interval(estimates: np.ndarray, full: np.ndarray, *, confidence: float, variant: str) -> np.ndarray:
    """(p, 2) intervals from refits (R, p) and the full-data estimate (p,)."""
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(estimates, [alpha, 1.0 - alpha], axis=0)
    if variant == "percentile":
        return np.stack([low, high], axis=1)
    if variant == "basic":
        return np.stack([2 * full - high, 2 * full - low], axis=1)
    raise ValueError(f"variant must be one of {VARIANTS}, not {variant!r}")


def bootstrap(
    refit: Refitter,
    by_episode: sp.csr_matrix,
    full: np.ndarray,
    *,
    confidence: float,
    resamples: int,
    seed: int,
    bounds: tuple[float, float] | None = None,
    variant: str = INTERVAL_VARIANT,
    progress: Progress | None = None,
    workers: int | None = None,
    groups: np.ndarray | None = None,
    executor: Executor | None = None,
) -> BootstrapResult:
    """Refit `resamples` resamples of the episodes (rows of `by_episode`, (E, S * A)) and bound every parameter.

    Args:
        full: (p,) the full-data estimate (the basic interval reflects around it).
        bounds: clip the intervals to these (the fit's ±rmax: a reflected end may not pass them).
        progress: called as progress("resamples", done, resamples) while the refits come back.
        workers: processes (default: the cores; 1 runs in this process).
        executor: where the refits run instead (`irl_core.support.executor`: a Dask cluster), in batches
            of at least `MIN_TASK_S` each; the same seed gives the same intervals anywhere.
        groups: (E,) the group of each episode (a participant): resample groups, then episodes
            within them (`two_level_weights`); None resamples the episodes alone.
    """
    weights = (resample_weights(by_episode.shape[0], resamples, seed) if groups is None
               else two_level_weights(groups, resamples, seed))
    if executor is None:
        executor = LocalPool(min(workers or os.cpu_count() or 1, resamples))
    estimates = np.full((resamples, full.size), np.nan)
    done = 0

    def returned(rows: np.ndarray, refits: np.ndarray) -> None:
        nonlocal done
        estimates[rows] = refits
        done += rows.size
        if progress:
            progress("resamples", done, resamples)

    if executor.workers <= 1 and not executor.remote:
        for i in range(resamples):
            returned(np.array([i]), _refit_rows(refit, by_episode, weights[i : i + 1], np.array([i])))
    else:
        chunks = _chunks(refit, by_episode, weights, executor, returned)
        executor.run(_refit_rows, [(weights[chunk], chunk) for chunk in chunks], shared=(refit, by_episode),
                     on_result=lambda i, refits: returned(chunks[i], refits),
                     # A batch lost with its worker stays NaN: counted in `failed`, as a refit that raised.
                     on_lost=lambda i, reason: returned(chunks[i], np.full((chunks[i].size, full.size), np.nan)))
    ok = ~np.isnan(estimates).any(axis=1)
    if not ok.any():  # nothing to take quantiles of: every interval unknown (`failed` says why)
        return BootstrapResult(estimates=estimates, intervals=np.full((full.size, 2), np.nan), confidence=confidence,
                               variant=variant, failed=resamples)
    intervals = interval(estimates[ok], full, confidence=confidence, variant=variant)
    if bounds is not None:
        intervals[: refit.unknowns.k] = np.clip(intervals[: refit.unknowns.k], *bounds)
    return BootstrapResult(estimates=estimates, intervals=intervals, confidence=confidence, variant=variant,
                           failed=int((~ok).sum()))


def _refit_rows(refit: Refitter, by_episode: sp.csr_matrix, weights: np.ndarray, numbers: np.ndarray) -> np.ndarray:
    """(len(weights), p) the refits of resamples given as episode multiplicities (n, E) and their numbers (n,); a
    row of NaN where the solver failed (counted, not fatal: the other refits still bound)."""
    shape = (refit.mdp.n_states, refit.mdp.n_actions)
    out = np.full((len(weights), refit.size), np.nan)
    for i, (w, number) in enumerate(zip(weights, numbers)):
        counts = np.asarray(by_episode.T @ w).reshape(shape)
        try:
            out[i] = refit(counts, resample=int(number))
        except Stopped:
            raise
        except Exception:  # noqa: BLE001 - one failed resample must not lose the others
            continue
    return out


# A batch of refits sent to a remote executor takes at least this long (seconds), so that its message
# costs little beside its work.
MIN_TASK_S = 0.1
# Batches per worker: enough that a slow batch does not leave the others idle at the end.
BATCHES_PER_WORKER = 8


def _chunks(refit: Refitter, by_episode: sp.csr_matrix, weights: np.ndarray, executor: Executor,
            returned: Callable[[np.ndarray, np.ndarray], None]) -> list[np.ndarray]:
    """The resamples' rows in batches for `executor`: `BATCHES_PER_WORKER` per worker, and for a remote one
    each of at least `MIN_TASK_S`, sized by timing the first refit here (handed to `returned`)."""
    rows = np.arange(len(weights))
    size = 1
    if executor.remote:
        start = time.perf_counter()
        returned(rows[:1], _refit_rows(refit, by_episode, weights[:1], rows[:1]))
        size = int(np.ceil(MIN_TASK_S / max(time.perf_counter() - start, 1e-6)))
        rows = rows[1:]
    count = max(1, min(rows.size // max(size, 1), executor.workers * BATCHES_PER_WORKER))
    return [chunk for chunk in np.array_split(rows, count) if chunk.size]
