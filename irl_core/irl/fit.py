"""`fit`: one entry point for the inverse-RL methods in README "Fitting a reward" and docs/answers.md.

It builds the unknowns and the Q map once, chooses the method (``auto``: lp for a
deterministic expert whose lp is feasible, else maxent with beta estimated), runs it,
optionally bounds every unknown (`--intervals`: the identified set for lp, a bootstrap
confidence interval for maxent and loss), evaluates an agent trained on the fitted reward
in the true world, and returns a `FitResult` with notes a researcher should read: which
method auto chose and why, rewards the bound rather than the data decided, a loss
minimiser that is not unique, an optimiser that stopped early, a beta the data cannot fix.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from irl_core.demonstrations import Demonstrations
from irl_core.irl.bootstrap import Refit, bootstrap
from irl_core.irl.evaluation import evaluate
from irl_core.irl.intervals import reward_intervals
from irl_core.irl.loss import STALL_TOLERANCE, fit_loss
from irl_core.irl.lp import Progress, solve_margin_lp
from irl_core.irl.margin import lp_constraints
from irl_core.irl.maxent import curvature_scale, fit_maxent, identification
from irl_core.irl.options import FITTERS, FitOptions
from irl_core.irl.qmap import QMap, build_qmap, build_unknowns
from irl_core.irl.result import BadInputError, FitResult, InfeasibleError, at_bound
from irl_core.stopping import Stopped, stop_when

METHODS = FITTERS


@dataclasses.dataclass
class _Fitted:
    """One method's answer before the intervals: theta (k,), V (S,), beta (maxent's), status, notes,
    and whether the lp was solved by the interior point method (so are its intervals)."""

    method: str
    theta: np.ndarray
    V: np.ndarray
    beta: float | None = None
    beta_auto: bool = False
    status: str = "optimal"
    notes: list[str] = dataclasses.field(default_factory=list)
    interior: bool = False
    unique: bool | None = None


def fit(
    demos: Demonstrations,
    options: FitOptions | None = None,
    /,
    *,
    progress: Progress | None = None,
    workers: int | None = None,
    stop: Callable[[], bool] | None = None,
    **settings,
) -> FitResult:
    """Fit the state rewards that explain `demos` with `options` (or `FitOptions(**settings)`).

    Args:
        progress: called as progress(stage, done, total) as long work goes on: the lp's
            ``rounds`` (total None), the ``intervals`` LPs done, the bootstrap's ``resamples``.
        workers: processes for the bootstrap (default: the cores).
        stop: asked at every LP iteration, every solve of maxent's soft Bellman equations
            and every progress report; once it says True the fit raises `Stopped` (a
            fitting thread whose answer is no longer wanted).

    Raises `BadInputError` (no demonstrated steps; `InfeasibleError` when the lp has no
    solution), `SolverError` or `Stopped`.
    """
    options = dataclasses.replace(options or FitOptions(), **settings) if settings else (options or FitOptions())
    if stop is not None:
        with stop_when(stop):
            return fit(demos, options, progress=_stopping(progress, stop), workers=workers)
    if demos.counts.sum() <= 0:
        raise BadInputError("the recordings contain no steps: there is nothing to fit")
    start = time.perf_counter()
    mdp = demos.mdp
    unknowns = build_unknowns(mdp, reward_cells=options.reward_cells, tie=options.tie)
    qmap = build_qmap(mdp, unknowns)
    notes: list[str] = []
    if unknowns.k == 0:
        notes.append("nothing to fit: every cell is ground, which --reward-cells special keeps at 0; "
                     "try --reward-cells all")

    if options.method == "auto":
        fitted = _auto(qmap, demos, options, progress=progress)
    else:
        fitted = _run(options.method, qmap, demos, options, beta=options.maxent_beta(chosen_by_auto=False),
                      progress=progress)
    notes += fitted.notes

    bounds, kind = None, None
    if options.intervals and unknowns.k:
        bounds, kind = _intervals(fitted, qmap, demos, options, notes, progress=progress, workers=workers)

    bounded = [label for label, value in zip(unknowns.labels, fitted.theta) if at_bound(value, options.rmax)]
    if bounded:
        notes.append(
            f"at ±rmax: {', '.join(bounded)}; there the bound, not the demonstrations, set the value"
        )
    R_S = unknowns.state_rewards(fitted.theta)
    return FitResult(
        method=fitted.method,
        options=options,
        beta=fitted.beta,
        beta_auto=fitted.beta_auto,
        R_S=R_S,
        V=np.asarray(fitted.V, dtype=float),
        theta=np.asarray(fitted.theta, dtype=float),
        unknowns=unknowns,
        intervals=bounds,
        interval_kind=kind,
        demos=demos,
        evaluation=evaluate(mdp, R_S),
        status=fitted.status,
        elapsed_s=time.perf_counter() - start,
        notes=notes,
    )


def _stopping(progress: Progress | None, stop: Callable[[], bool]) -> Progress:
    """`progress` that first raises `Stopped` once `stop()` says so."""

    def heard(stage: str, done: int, total: int | None) -> None:
        if stop():
            raise Stopped()
        if progress is not None:
            progress(stage, done, total)

    return heard


def _auto(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None) -> _Fitted:
    """The auto method's choice: lp for a deterministic expert whose lp is feasible, else maxent (beta auto)."""
    acted = demos.counts[demos.demonstrated]
    mixed = int(((acted > 0).sum(axis=1) > 1).sum())
    if mixed == 0:
        try:
            fitted = _run("lp", qmap, demos, options, beta=None, progress=progress)
        except InfeasibleError:
            why = ("every demonstrated cell shows a single action, but no reward within ±rmax makes "
                   "those actions optimal")
        else:
            fitted.notes.insert(0, "method auto chose lp: every demonstrated cell shows a single action "
                                   "and some reward makes those actions optimal")
            return fitted
    else:
        why = (f"{mixed} of {len(acted)} demonstrated cells show more than one action, so no single "
               "optimal policy was demonstrated (noisy play, as a person's)")
    beta = options.maxent_beta(chosen_by_auto=True)
    fitted = _run("maxent", qmap, demos, options, beta=beta, progress=progress)
    what = "beta estimated with the rewards" if beta == "auto" else f"beta {beta:g}"
    fitted.notes.insert(0, f"method auto chose maxent ({what}): {why}")
    return fitted


def _run(method: str, qmap: QMap, demos: Demonstrations, options: FitOptions, *, beta,
         progress: Progress | None = None) -> _Fitted:
    """Fit with one method (lp, loss or maxent)."""
    if method == "lp":
        solution = solve_margin_lp(lp_constraints(qmap, demos.most_frequent, rmax=options.rmax), lam=options.lam,
                                   progress=progress)
        theta, V = qmap.split(solution.x)
        fitted = _Fitted("lp", theta, V, status=solution.status, interior=solution.interior)
        if solution.interior:
            why = (f"the dual simplex failed ({solution.simplex_failure})" if solution.simplex_failure else
                   f"this world's LP has {solution.first_rows:,} rows in its first round (the simplex is used up "
                   f"to {solution.interior_rows:,})")
            fitted.notes.append(
                f"lp solved by the interior point method, as {why}; the gap between its margin and the "
                f"dual bound on the largest is {100 * solution.gap:.2g}% of it, so the reward is a "
                "near-maximiser of the margin")
        return fitted
    if method == "loss":
        solution = fit_loss(qmap, demos.policy, rmax=options.rmax, lam=options.lam)
        theta, V = qmap.split(solution.x)
        return _Fitted("loss", theta, V, status="optimal_inaccurate" if solution.gap > STALL_TOLERANCE else "optimal",
                       notes=list(solution.notes), unique=solution.unique)
    solution = fit_maxent(qmap.mdp, qmap.unknowns, demos.counts, beta=beta, rmax=options.rmax)
    fitted = _Fitted("maxent", solution.theta, solution.V, beta=solution.beta, beta_auto=beta == "auto")
    if not solution.converged:
        fitted.status = "not_converged"
        fitted.notes.append(f"maxent stopped before converging: {solution.message.lower()}")
    if beta != "auto":
        fitted.notes.append(f"beta fixed at {solution.beta:g}, not estimated (--beta auto estimates it from the data)")
    else:
        fitted.notes.append(f"beta estimated by maximum likelihood: {solution.beta:.3g}")
        reason = identification(qmap.mdp)
        if solution.beta_at_bound:
            reason = (f"beta is not identified: the estimate ran to the end of its range ({solution.beta:.3g}); "
                      "the demonstrations do not fix the reward's scale")
        if reason:
            fitted.notes.append(reason)
    return fitted


def _intervals(fitted: _Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[str], *,
               progress: Progress | None, workers: int | None) -> tuple[np.ndarray | None, str | None]:
    """(k, 2) intervals and their kind (``identified`` or ``confidence``), or (None, None) with a note why not."""
    if fitted.method == "lp":
        constraints = lp_constraints(qmap, demos.most_frequent, rmax=options.rmax)
        try:
            bounds, _ = reward_intervals(constraints, interior=fitted.interior, progress=progress)
        except InfeasibleError:
            notes.append("intervals not computed: the most frequent actions are not optimal for any reward "
                         "within ±rmax, so the lp constraints they come from are empty")
            return None, None
        if fitted.interior:
            notes.append(f"intervals by the interior point method, as the fit: each of the {2 * qmap.k} interval LPs "
                         "solved from nothing, and each end moved out by its LP's gap to the dual bound, so the "
                         "intervals hold the identified set (they may be a little wider)")
        return bounds, "identified"
    if fitted.unique is False:
        # Resampling would move only the pick among equally good rewards: no interval for the reward.
        notes.append("intervals not computed: many rewards minimise the loss equally, so resampling episodes "
                     "would show only how the smallest-||R_S||_1 pick among them moves, not which rewards the "
                     "data allow; for a deterministic expert --method lp --intervals gives every value the "
                     "demonstrations allow")
        return None, None
    episodes = 0 if demos.by_episode is None else demos.by_episode.shape[0]
    if episodes < 2:
        notes.append("intervals not computed: a confidence interval comes from resampling whole episodes, and "
                     + ("these demonstrations hold one episode, which says nothing about the next"
                        if episodes == 1 else "these demonstrations do not keep their episodes"))
        return None, None
    beta = fitted.beta if fitted.method == "maxent" else 1.0
    scale = None
    if fitted.method == "maxent":
        scale = curvature_scale(qmap.mdp, qmap.unknowns, demos.counts, theta=fitted.theta, beta=beta,
                                estimate=fitted.beta_auto, rmax=options.rmax)
    refit = Refit(mdp=qmap.mdp, unknowns=qmap.unknowns, method=fitted.method, rmax=options.rmax, lam=options.lam,
                  beta="auto" if fitted.beta_auto else beta, start=(fitted.theta, beta), scale=scale,
                  start_V=fitted.V if fitted.method == "maxent" else None)
    full = np.append(fitted.theta, fitted.beta) if fitted.beta_auto else fitted.theta
    result = bootstrap(refit, demos.by_episode, full, confidence=options.confidence, resamples=options.resamples,
                       seed=options.seed, bounds=(-options.rmax, options.rmax), progress=progress, workers=workers,
                       groups=demos.episode_groups)
    if result.failed:
        notes.append(f"{result.failed} of {options.resamples} resamples failed to fit and were left out")
    bounds = result.intervals[: qmap.k]
    inside = ~at_bound(bounds, options.rmax).any(axis=1)
    stayed = inside & (bounds[:, 1] - bounds[:, 0] <= 1e-9 * np.maximum(1.0, np.abs(bounds).max(axis=1)))
    if stayed.any() and stayed.sum() == inside.sum():
        # Zero width inside the bound: the refits never left the full fit, which measures nothing.
        why = (", as for a deterministic expert, whose beta would grow without end (--method lp fits one)"
               if fitted.beta_auto else "")
        notes.append("intervals not computed: every resample's refit stayed at the full fit's value, so they "
                     f"would show no sampling noise; the likelihood is flat around this estimate{why}")
        return None, None
    if stayed.any():
        labels = ", ".join(label for label, flat in zip(qmap.unknowns.labels, stayed) if flat)
        notes.append(f"the refits never moved {labels}: their intervals have no width and show no sampling noise "
                     "(the likelihood is flat in them)")
    if fitted.beta_auto:
        low, high = result.intervals[-1]
        notes.append(f"beta's {options.confidence:.0%} confidence interval: {low:.3g} to {high:.3g}")
    if episodes < 10:
        notes.append(f"only {episodes} episodes: a bootstrap interval from so few is rough (it tends to be too narrow)")
    return bounds, "confidence"
