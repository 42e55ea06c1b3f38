"""A fit's intervals, of the kind its method has (`irl_core.irl.choices`): the identified set for lp
(`identified`), a bootstrap over episodes for maxent and loss (`bootstrap`), widened where the
fit knows the resamples cannot move (a held reward's bound, a flat combination, a rival planning model).
"""

from __future__ import annotations

import numpy as np

from irl_core.irl.choices import method
from irl_core.irl.fitters import Fitted
from irl_core.irl.intervals.bootstrap import Refit, Refitter, bootstrap
from irl_core.irl.intervals.honest import ZERO_WIDTH
from irl_core.irl.intervals.identified import reward_intervals
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.lp.solve import Progress
from irl_core.irl.maxent import curvature_scale
from irl_core.irl.notes import Note
from irl_core.irl.options import FitOptions
from irl_core.irl.people import PlayerFit, PlayerRefit
from irl_core.irl.people import curvature_scale as people_curvature_scale
from irl_core.irl.qmap import QMap
from irl_core.irl.result import InfeasibleError, at_bound
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.executor import Executor


def fit_intervals(fitted: Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[Note], *,
               progress: Progress | None, workers: int | None,
               executor: Executor | None) -> tuple[np.ndarray | None, str | None]:
    """(k, 2) intervals and their kind (the method's), or (None, None) with a note why not."""
    kind = method(fitted.method).interval_kind
    if kind == "identified":
        bounds = _identified(fitted, qmap, demos, options, notes, progress=progress)
    else:
        bounds = _confidence(fitted, qmap, demos, options, notes, progress=progress, workers=workers,
                             executor=executor)
    return (None, None) if bounds is None else (bounds, kind)


def _identified(fitted: Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[Note], *,
                progress: Progress | None) -> np.ndarray | None:
    """(k, 2) every value the lp constraints allow, or None with a note why not."""
    constraints = lp_constraints(qmap, demos.most_frequent, rmax=options.rmax)
    try:
        bounds, _ = reward_intervals(constraints, interior=fitted.interior, progress=progress)
    except InfeasibleError:
        notes.append(Note("intervals_not_computed", "intervals not computed: the most frequent actions are not "
                                                    "optimal for any reward within ±rmax, so the lp constraints they "
                                                    "come from are empty"))
        return None
    if fitted.interior:
        notes.append(Note("intervals_interior", f"intervals by the interior point method, as the fit: each of the "
                                                f"{2 * qmap.k} interval LPs solved from nothing, and each end moved "
                                                "out by its LP's gap to the dual bound, so the intervals hold the "
                                                "identified set (they may be a little wider)"))
    return bounds


def _confidence(fitted: Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[Note], *,
                progress: Progress | None, workers: int | None, executor: Executor | None) -> np.ndarray | None:
    """(k, 2) bootstrap confidence intervals over episodes, or None with a note why not (the refits on
    `workers` processes, or on `executor`)."""
    if fitted.unique is False:
        # Resampling would move only the pick among equally good rewards: no interval for the reward.
        notes.append(Note("intervals_not_computed", "intervals not computed: many rewards minimise the loss equally, "
                                                    "so resampling episodes would show only how the "
                                                    "smallest-||R_S||_1 pick among them moves, not which rewards the "
                                                    "data allow; for a deterministic expert {method=lp} "
                                                    "{intervals=True} gives every value the demonstrations allow"))
        return None
    episodes = 0 if demos.by_episode is None else demos.by_episode.shape[0]
    if episodes < 2:
        notes.append(Note("intervals_not_computed", "intervals not computed: a confidence interval comes from "
                                                    "resampling whole episodes, and "
                                                    + ("these demonstrations hold one episode, which says nothing "
                                                       "about the next" if episodes == 1 else
                                                       "these demonstrations do not keep their episodes")))
        return None
    if fitted.people is not None:
        full = fitted.people.parameters()
    elif fitted.beta_auto:
        assert fitted.beta is not None, "an estimated beta"
        full = np.append(fitted.theta, fitted.beta)
    else:
        full = fitted.theta
    refit = _refit(fitted, qmap, demos, options)
    result = bootstrap(refit, demos.by_episode, full, confidence=options.confidence,
                       resamples=options.resamples, seed=options.seed, bounds=(-options.rmax, options.rmax),
                       progress=progress, workers=workers, groups=demos.episode_groups, executor=executor)
    if result.failed == options.resamples:
        notes.append(Note("intervals_not_computed", f"intervals not computed: every one of the {options.resamples} "
                                                    "resamples failed to refit"))
        return None
    if result.failed:
        notes.append(Note("resamples_failed", f"{result.failed} of {options.resamples} resamples failed to fit and "
                                              "were left out"))
    bounds = result.intervals[: qmap.k]
    others = [] if fitted.rival is None else [fitted.rival]
    for other in others + [fit for fit in fitted.close if fit is not fitted.rival]:
        # The other planning assumption's interval (and with `union` every close model's) is taken to have the
        # same sampling spread about its own estimate (a bootstrap each would multiply the time): the union
        # covers them all.
        shift = other.theta - fitted.theta
        bounds = np.clip(np.stack([np.minimum(bounds[:, 0], bounds[:, 0] + shift),
                                   np.maximum(bounds[:, 1], bounds[:, 1] + shift)], axis=1),
                         -options.rmax, options.rmax)
    if fitted.held_upper is not None:
        held = ~np.isnan(fitted.held_upper)
        bounds[held] = np.column_stack([np.full(held.sum(), -options.rmax), fitted.held_upper[held]])
    if fitted.together is not None:
        # The refits start where the full fit stopped, and nothing moves them along a flat combination.
        along = ~np.isnan(fitted.together[:, 0])
        bounds[along] = np.column_stack([np.minimum(bounds[along, 0], fitted.together[along, 0]),
                                         np.maximum(bounds[along, 1], fitted.together[along, 1])])
    if not _moved(bounds, fitted, qmap, options, notes):
        return None
    if isinstance(refit, PlayerRefit) and refit.draws_trials:
        notes.append(Note("hand_resampled", f"each resample drew the {len(demos.calibration)} calibration trials "
                                            "again and held the hand they measure, so the intervals carry the "
                                            "hand's sampling error"))
    if fitted.beta_auto and fitted.people is None:
        low, high = result.intervals[-1]
        notes.append(Note("beta_interval", f"beta's {options.confidence:.0%} confidence interval: {low:.3g} to "
                                           f"{high:.3g}"))
    return bounds


def _refit(fitted: Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions) -> Refitter:
    """How the bootstrap refits `fitted`'s method, warm-started from it (a temperature model also from
    its beta, its soft V and its variables' curvature there)."""
    if fitted.people is not None:
        return _player_refit(fitted.people, qmap, demos, options)
    if fitted.beta is None:
        return Refit(mdp=qmap.mdp, unknowns=qmap.unknowns, method=fitted.method, rmax=options.rmax, lam=options.lam,
                     beta=1.0, start=(fitted.theta, 1.0))
    scale = curvature_scale(qmap.mdp, qmap.unknowns, demos.counts, theta=fitted.theta, beta=fitted.beta,
                            estimate=fitted.beta_auto, rmax=options.rmax)
    return Refit(mdp=qmap.mdp, unknowns=qmap.unknowns, method=fitted.method, rmax=options.rmax, lam=options.lam,
                 beta="auto" if fitted.beta_auto else fitted.beta, start=(fitted.theta, fitted.beta), scale=scale,
                 start_V=fitted.V)


def _player_refit(solution: PlayerFit, qmap: QMap, demos: Demonstrations, options: FitOptions) -> PlayerRefit:
    """How the bootstrap refits a model of people: from its fit, over its variables' curvature there."""
    scale = people_curvature_scale(qmap.mdp, qmap.unknowns, demos.counts, solution, rmax=options.rmax)
    return PlayerRefit(qmap.mdp, qmap.unknowns, solution.model, options.rmax, (solution.theta, solution.player),
                       solution.V1, scale, trials=demos.calibration if demos.calibration.shape[0] else None,
                       seed=options.seed)


def _moved(bounds: np.ndarray, fitted: Fitted, qmap: QMap, options: FitOptions, notes: list[Note]) -> bool:
    """Whether the refits moved any unknown inside the bound (else the intervals measure nothing, with a note);
    a note names the ones they never moved."""
    inside = ~at_bound(bounds, options.rmax).any(axis=1)
    stayed = inside & (bounds[:, 1] - bounds[:, 0] <= ZERO_WIDTH * max(1.0, options.rmax))
    if stayed.any() and stayed.sum() == inside.sum():
        # Zero width inside the bound: the refits never left the full fit, which measures nothing.
        why = (", as for a deterministic expert, whose beta would grow without end ({method=lp} fits one)"
               if fitted.beta_auto else "")
        notes.append(Note("intervals_not_computed", "intervals not computed: every resample's refit stayed at the "
                                                    "full fit's value, so they would show no sampling noise; the "
                                                    f"likelihood is flat around this estimate{why}"))
        return False
    if stayed.any():
        labels = ", ".join(label for label, flat in zip(qmap.unknowns.labels, stayed) if flat)
        notes.append(Note("refits_never_moved", f"the refits never moved {labels}: their intervals have no width and "
                                                "show no sampling noise (the likelihood is flat in them)"))
    return True

