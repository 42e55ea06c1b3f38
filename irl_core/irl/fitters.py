"""The fitters: one function per method of `irl_core.irl.choices`, in `FITTERS` under the method's name.

Each takes the Q map, the demonstrations and the options and returns a `Fitted`: one method's answer
before the intervals (`irl_core.irl.intervals`) and the checks `fit` adds. ``auto``'s runs another
method's (lp for a deterministic expert whose lp is feasible, else maxent with beta estimated); maxent's
runs the paper's Boltzmann expert, a model of people (`irl_core.irl.people`) or, on a time world's
holds, the timing model (`irl_core.irl.timing`), as `choices.player_model_for` decides.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from irl_core.irl.choices import AUTO as PLAYER_AUTO
from irl_core.irl.choices import Player, player_model, player_model_for
from irl_core.irl.fit_check import FitCheck
from irl_core.irl.identification import units_unfixed_why
from irl_core.irl.loss.solve import STALL_TOLERANCE, fit_loss
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.lp.solve import Progress, solve_margin_lp
from irl_core.irl.maxent import MaxEntSolution, fit_maxent, soft_bellman
from irl_core.irl.notes import Note
from irl_core.irl.options import FitOptions
from irl_core.irl.people import (
    FLAT_DROP,
    MAX_COMBINED,
    NEARLY_FLAT,
    PlayerFit,
    choose_player_model,
    close_models,
    fit_given_model,
    hand_from_trials,
    note_of_bounds,
    people_checks,
    planning_rival,
)
from irl_core.irl.qmap import QMap
from irl_core.irl.result import BadInputError, InfeasibleError
from irl_core.irl.timing.fit import fit_timing, timing_chooser, timing_policy
from irl_core.irl.timing.slip_curve import SlipCurve, fit_slip_curve
from irl_core.players.experts import Chooser
from irl_core.recordings.demonstrations import Demonstrations

Fitter = Callable[..., "Fitted"]


@dataclasses.dataclass
class Fitted:
    """One method's answer before the intervals: theta (k,), V (S,), beta (a temperature model's), status,
    notes, and whether the lp was solved by the interior point method (so are its intervals)."""

    method: str
    theta: np.ndarray
    V: np.ndarray
    beta: float | None = None
    beta_auto: bool = False
    status: str = "optimal"
    notes: list[Note] = dataclasses.field(default_factory=list)
    interior: bool = False
    unique: bool | None = None
    player_model: str | None = None
    player: Player | None = None
    observed_policy: np.ndarray | None = None
    people: PlayerFit | None = None
    rival: PlayerFit | None = None
    close: tuple[PlayerFit, ...] = ()  # with `union`: the other models held-out episodes do not tell apart
    held_upper: np.ndarray | None = None  # (k,) a held reward's upper bound (`people.checks`)
    together: np.ndarray | None = None  # (k, 2) a reward's range along a combination the data do not pin (`laplace`)
    flat: np.ndarray | None = None  # (k,) -1 / +1 where the data bound a reward on one side only (`people.flat`)
    curve: SlipCurve | None = None  # the timing fit's slip curve, estimated with the rewards
    own_intervals: np.ndarray | None = None  # (k, 2) the timing fit's sandwich intervals
    chooser: Chooser | None = None  # the timing model's player over continuous holds, for the fit check
    fit_check: FitCheck | None = None  # the fit check, where the fitter worked it out beside its other checks


def run_fitter(method: str, qmap: QMap, demos: Demonstrations, options: FitOptions, *,
         progress: Progress | None = None, workers: int = 1) -> Fitted:
    """Fit with `method`'s fitter (`options.method` is not read: auto runs another method with them), on up to
    `workers` processes where it has work side by side."""
    return FITTERS[method](qmap, demos, options, progress=progress, workers=workers)


def auto_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                workers: int = 1) -> Fitted:
    """The auto method's choice: the timing fit on a time world with recorded holds; else lp for a deterministic
    expert whose lp is feasible, else maxent (beta auto)."""
    holds = qmap.mdp.world.care == "time" and demos.hold_steps.shape[0] > 0
    if holds and _player_model(options, demos, qmap, after_auto=True) == "timing":
        fitted = run_fitter("maxent", qmap, demos, dataclasses.replace(options, player_model="timing"), progress=progress,
                      workers=workers)
        fitted.notes.insert(0, Note("auto_chose", "method auto chose maxent with the timing model: on a time world "
                                                  "the exact holds show the care taken, and the slips the curve"))
        return fitted
    acted = demos.counts[demos.demonstrated]
    mixed = int(((acted > 0).sum(axis=1) > 1).sum())
    if mixed == 0:
        try:
            fitted = run_fitter("lp", qmap, demos, options, progress=progress, workers=workers)
        except InfeasibleError:
            why = ("every demonstrated cell shows a single action, but no reward within ±rmax makes "
                   "those actions optimal")
        else:
            fitted.notes.insert(0, Note("auto_chose", "method auto chose lp: every demonstrated cell shows a single "
                                                      "action and some reward makes those actions optimal"))
            return fitted
    else:
        why = (f"{mixed} of {len(acted)} demonstrated cells show more than one action, so no single "
               "optimal policy was demonstrated (noisy play, as a person's)")
    beta = options.maxent_beta(chosen_by_auto=True)
    fitted = run_fitter("maxent", qmap, demos, dataclasses.replace(options, beta=beta), progress=progress, workers=workers)
    what = "beta estimated with the rewards" if beta == "auto" else f"beta {beta:g}"
    fitted.notes.insert(0, Note("auto_chose", f"method auto chose maxent ({what}): {why}"))
    return fitted


def _player_model(options: FitOptions, demos: Demonstrations, qmap: QMap, *, after_auto: bool) -> str:
    """The player model maxent runs here (`choices.player_model_for`, the one place that decides it)."""
    return player_model_for(options.player_model, after_auto=after_auto,
                            fixed_beta=isinstance(options.beta, (int, float)),
                            holds=qmap.mdp.world.care == "time" and demos.hold_steps.shape[0] > 0)


def lp_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
              workers: int = 1) -> Fitted:
    """The simple IRL agent: the margin LP over the most frequent actions."""
    solution = solve_margin_lp(lp_constraints(qmap, demos.most_frequent, rmax=options.rmax), lam=options.lam,
                               progress=progress)
    theta, V = qmap.split(solution.x)
    fitted = Fitted("lp", theta, V, status=solution.status, interior=solution.interior)
    if solution.interior:
        why = (f"the dual simplex failed ({solution.simplex_failure})" if solution.simplex_failure else
               f"this world's LP has {solution.first_rows:,} rows in its first round (the simplex is used up "
               f"to {solution.interior_rows:,})")
        fitted.notes.append(Note("lp_interior", f"lp solved by the interior point method, as {why}; the gap between "
                                                f"its margin and the dual bound on the largest is "
                                                f"{100 * solution.gap:.2g}% of it, so the reward is a near-maximiser "
                                                "of the margin"))
    return fitted


def loss_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                workers: int = 1) -> Fitted:
    """The loss IRL agent: the convex loss over the demonstrated action frequencies."""
    solution = fit_loss(qmap, demos.policy, rmax=options.rmax, lam=options.lam)
    theta, V = qmap.split(solution.x)
    return Fitted("loss", theta, V, status="optimal_inaccurate" if solution.gap > STALL_TOLERANCE else "optimal",
                   notes=list(solution.notes), unique=solution.unique)


def maxent_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                  workers: int = 1) -> Fitted:
    """Maximum-entropy IRL: the paper's Boltzmann expert with beta given or estimated (`FitOptions.maxent_beta`),
    or a model of people (`FitOptions.player_model`, `irl_core.irl.people.fit`)."""
    chosen_by_auto = options.method == "auto"
    model = _player_model(options, demos, qmap, after_auto=chosen_by_auto)
    if model == "timing":
        return timing_fitter(qmap, demos, options, progress=progress)
    if model != "boltzmann":
        return _fit_people(qmap, demos, options, model=model, workers=workers)
    beta = options.maxent_beta(chosen_by_auto=chosen_by_auto)
    solution = fit_maxent(qmap.mdp, qmap.unknowns, demos.counts, beta=beta, rmax=options.rmax)
    plan = soft_bellman(qmap.mdp, qmap.unknowns.state_rewards(solution.theta), beta=solution.beta, V0=solution.V)
    return Fitted("maxent", solution.theta, solution.V, beta=solution.beta, beta_auto=beta == "auto",
                   status="optimal" if solution.converged else "not_converged",
                   notes=_maxent_notes(solution, qmap, estimated=beta == "auto"), player_model="boltzmann",
                   player=Player(solution.beta), observed_policy=plan.policy)


# From this many states a people fit runs its candidates' default starts, the folds' refits and the held rewards'
# bounds on several processes (`workers`): on the 25-state mud world the pool's start took what it saved, on a
# 121-state cliff world it saved 17% of 2.5 s (two cores), on walled-24 2.5 s of 9.
PEOPLE_PARALLEL_STATES = 100


def _fit_people(qmap: QMap, demos: Demonstrations, options: FitOptions, *, model: str, workers: int = 1) -> Fitted:
    """maxent with a model of people: the one given, or the one held-out episodes choose (``auto``), with a
    note saying which and why, and the other planning assumption kept as a rival where the data cannot tell
    whether the player plans for the hand (its intervals join the chosen model's)."""
    mdp, unknowns = qmap.mdp, qmap.unknowns
    if mdp.n_states < PEOPLE_PARALLEL_STATES:
        workers = 1
    notes: list[Note] = []
    rival = None
    close: tuple[PlayerFit, ...] = ()
    hand = None
    # With one level there is no hand to speak of: person and naive are one model, and a level's noise nothing.
    levels = mdp.levels > 1
    if demos.calibration.shape[0] and levels:
        measured = hand_from_trials(demos.calibration, mdp.levels)
        hand = measured.known()
        notes.append(Note("hand_calibrated", f"the hand from {measured.trials} calibration trials: bias "
                                             f"{measured.bias:+.2f} levels, sigma {measured.sigma:.2f} levels "
                                             "(held fixed in every model with a hand)"))
    if model == PLAYER_AUTO:
        if demos.by_episode is None:
            raise BadInputError("player_model auto needs the demonstrations' episodes (held-out episodes choose it); "
                                "give {player_model=person} instead", code="no_episodes")
        choice = choose_player_model(mdp, unknowns, demos.by_episode, rmax=options.rmax, seed=options.seed,
                                     hand=hand, workers=workers)
        solution = choice.fits[choice.name]
        notes.append(Note("player_model", choice.reason))
        rival = planning_rival(choice) if levels else None
        if rival is not None:
            notes.append(Note("planning_not_identified",
                              f"whether the player plans for the hand's noise is not told apart by the held-out "
                              f"episodes ({solution.model.name} and {rival.model.name} agree within their "
                              "noise): the reward's size depends on it, so the intervals cover both"))
        if options.union:
            close = close_models(choice)
            if close:
                notes.append(Note("models_joined", "the intervals join those of every player model the held-out "
                                                   f"episodes do not tell from {solution.model.name} beyond their "
                                                   f"noise ({', '.join(fit.model.name for fit in close)}; "
                                                   "{union}): each model's estimate with the chosen model's "
                                                   "spread around it"))
    else:
        solution = fit_given_model(mdp, unknowns, demos.counts, model=player_model(model).with_hand(hand),
                                   rmax=options.rmax)
        notes.append(Note("player_model", f"player model {model}, as asked: {solution.model.summary}"))
    player = solution.player
    words = [f"beta {player.beta:.3g}"] + ([f"the hand's sigma {player.sigma:.2g} levels"]
                                           if solution.model.searches_hand and levels else []) \
        + ([f"lapses {player.lapse:.2g}"] if solution.model.lapses else [])
    notes.append(Note("player_estimated", "player estimated by maximum likelihood with the rewards: " + ", ".join(words)))
    if not solution.converged:
        notes.append(Note("not_converged", f"the player model's fit stopped before converging: "
                                           f"{solution.message.lower()}"))
    if solution.beta_at_bound:
        notes.append(Note("not_identified", f"beta ran to the end of its range ({player.beta:.3g}): the intended "
                                            "choices look deterministic, so the data bound the rewards rather than "
                                            "pin them; read the intervals, not the points"))
    episodes = (demos.by_episode, demos.episode_facts) \
        if demos.by_episode is not None and demos.episode_facts is not None else None
    checks = people_checks(mdp, unknowns, demos.counts, solution, rmax=options.rmax, episodes=episodes,
                           seed=options.seed, workers=workers)
    if checks.held_upper is not None:
        notes.append(note_of_bounds(unknowns, checks.held_upper, solution.held))
    together = checks.together
    if together is None:
        notes.append(Note("combinations_unchecked", f"with over {MAX_COMBINED} free rewards, whether the data pin "
                                                    "some of them only in combination was not checked"))
    elif (~np.isnan(together[:, 0])).any():
        ranges = [f"{label} {value:.3g} ({low:.3g} to {high:.3g})" for label, value, (low, high)
                  in zip(unknowns.labels, solution.theta, together) if not np.isnan(low)]
        notes.append(Note("pinned_together", "pinned only loosely, together: the likelihood hardly changes along a "
                                             f"mix of them (its curvature there under {NEARLY_FLAT:g} of the "
                                             "best-pinned mix's), so each point is where the search stopped; along "
                                             f"that mix each can move this far at a cost under {FLAT_DROP:g} (point, "
                                             "then range): " + "; ".join(ranges)))
    V = solution.V1 / player.beta
    return Fitted("maxent", solution.theta, V, beta=player.beta, beta_auto=True,
                   status="optimal" if solution.converged else "not_converged", notes=notes,
                   player_model=solution.model.name, player=player, observed_policy=solution.plan.observed,
                   people=solution, rival=rival, close=close, held_upper=checks.held_upper, flat=checks.flat,
                   together=together, fit_check=checks.fit_check)


def timing_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                  workers: int = 1) -> Fitted:
    """maxent with the timing model (`irl_core.irl.timing.fit`): rewards, slip curve and player from the exact
    holds, started where the people fit over duration bins and the slips' own curve end."""
    mdp, unknowns = qmap.mdp, qmap.unknowns
    world = mdp.world
    if world.care != "time" or not demos.hold_steps.shape[0]:
        raise BadInputError("{player_model=timing} reads exact holds, which only a time world's recordings have",
                            code="timing_needs_holds")
    start = fit_given_model(mdp, unknowns, demos.counts, model=player_model("person"), rmax=options.rmax)
    curve = (None if options.slip_known else
             fit_slip_curve(demos.slip_outcomes, max_hold_ms=world.max_hold_ms, confidence=options.confidence))
    solution = fit_timing(mdp, unknowns, demos.hold_steps, rmax=options.rmax, cost_per_second=world.cost_per_second,
                          groups=demos.episode_groups, slip_known=options.slip_known, confidence=options.confidence,
                          start_theta=start.theta, start_curve=curve)
    player = Player(solution.beta, solution.sigma, solution.lapse)
    notes = [Note("player_estimated", f"player estimated with the rewards and the curve: the holds' timing noise "
                                      f"{100 * solution.sigma:.0f}% (sd of log hold {solution.sigma:.2g}), lapses "
                                      f"{solution.lapse:.2g}, beta {solution.beta:.3g} per point")]
    if not solution.converged:
        notes.append(Note("not_converged", f"the timing fit stopped before converging: {solution.message.lower()}"))
    if solution.interval_route == "scores":
        notes.append(Note("intervals_scores", "the intervals come from the spread of the participants' scores alone: "
                                              "the likelihood's curvature, measured by differences, was not positive "
                                              "definite (kinks where a best hold is clipped), so they assume the "
                                              "model is right"))
    if solution.theta_intervals is None:
        notes.append(Note("intervals_not_computed", "no intervals: the likelihood's curvature at the answer is not "
                                                    "positive definite (a flat direction the data do not pin)"))
    return Fitted("maxent", solution.theta, solution.plan.V, status="optimal" if solution.converged else
                   "not_converged", notes=notes, player_model="timing", player=player,
                   observed_policy=timing_policy(mdp, solution), curve=solution.curve,
                   chooser=timing_chooser(mdp, solution),
                   own_intervals=solution.theta_intervals)


def _maxent_notes(solution: MaxEntSolution, qmap: QMap, *, estimated: bool) -> list[Note]:
    """Whether maxent converged, its beta (fixed or estimated) and whether the data fix beta."""
    notes = []
    if not solution.converged:
        notes.append(Note("not_converged", f"maxent stopped before converging: {solution.message.lower()}"))
    if not estimated:
        notes.append(Note("beta_fixed", f"beta fixed at {solution.beta:g}, not estimated ({{beta=auto}} estimates "
                                        "it from the data)"))
        return notes
    notes.append(Note("beta_estimated", f"beta estimated by maximum likelihood: {solution.beta:.3g}"))
    # A held reward (the user's, or the reference) fixes the scale; else only the world's care cost can.
    unfixed = None if qmap.unknowns.held else units_unfixed_why(qmap.mdp.world)
    reason = None if unfixed is None else (f"beta is not identified: {unfixed}, so nothing fixes the reward's scale "
                                           "and only beta times R_S is estimated")
    if solution.beta_at_bound:
        reason = (f"beta is not identified: the estimate ran to the end of its range ({solution.beta:.3g}); "
                  "the demonstrations do not fix the reward's scale")
    if reason:
        notes.append(Note("not_identified", reason))
    return notes


# Every method's fitter under its registry name (a test holds the keys equal to `choices.METHODS`).
FITTERS: dict[str, Fitter] = {"auto": auto_fitter, "lp": lp_fitter, "loss": loss_fitter, "maxent": maxent_fitter}
