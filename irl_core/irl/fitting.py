"""`fit`: one entry point for the inverse-RL methods in docs/fitting.md and docs/answers.md.

It builds the unknowns and the Q map once, runs the method's fitter (named by its entry in
`irl_core.irl.fit_methods`; ``auto``'s chooses lp for a deterministic expert whose lp is
feasible, else maxent with beta estimated), optionally bounds every unknown (``intervals``:
the identified set, or a bootstrap confidence interval, by the method's interval kind),
evaluates an agent trained on the fitted reward in the true world, and returns a `FitResult`
with notes (`Note`) a researcher should read: which method auto chose and why, rewards the
bound rather than the data decided, a loss minimiser that is not unique, an optimiser that
stopped early, a beta the data cannot fix.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable

import numpy as np

import irl_core.irl.fit_methods as fit_methods
from irl_core.irl.bootstrap import Refit, Refitter, bootstrap
from irl_core.irl.evaluation import evaluate
from irl_core.irl.fit_check import FitCheck, fit_check
from irl_core.irl.hand import hand_from_trials
from irl_core.irl.intervals import reward_intervals
from irl_core.irl.laplace import MAX_COMBINED, NEARLY_FLAT
from irl_core.irl.loss import STALL_TOLERANCE, fit_loss
from irl_core.irl.lp import Progress, solve_margin_lp
from irl_core.irl.margin import lp_constraints
from irl_core.irl.maxent import MaxEntSolution, curvature_scale, fit_maxent, identification, soft_bellman
from irl_core.irl.notes import Note
from irl_core.irl.options import FitOptions
from irl_core.irl.people_checks import people_checks
from irl_core.irl.people_choice import ModelChoice, choose_player_model, fit_given_model, significantly_better
from irl_core.irl.people_fit import PlayerFit, PlayerRefit
from irl_core.irl.people_fit import curvature_scale as people_curvature_scale
from irl_core.irl.people_held import FLAT_DROP, note_of_bounds
from irl_core.irl.player_models import AUTO as PLAYER_AUTO
from irl_core.irl.player_models import Player, player_model
from irl_core.irl.qmap import QMap, build_qmap, build_unknowns
from irl_core.irl.result import BadInputError, FitResult, InfeasibleError, at_bound
from irl_core.irl.slip_curve import SlipCurve, fit_slip_curve
from irl_core.irl.timing_fit import fit_timing, timing_chooser, timing_policy
from irl_core.players.experts import Chooser
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.allocator import keep_freed_memory
from irl_core.support.executor import Executor
from irl_core.support.stopping import Stopped, stop_when
from irl_core.worlds.mdp import MDP, build_mdp
from irl_core.worlds.planning import greedy_actions

METHODS = fit_methods.FITTED


@dataclasses.dataclass
class _Fitted:
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
    held_upper: np.ndarray | None = None  # (k,) a held reward's upper bound (`people_flat.held_upper_bounds`)
    together: np.ndarray | None = None  # (k, 2) a reward's range along a combination the data do not pin (`laplace`)
    curve: SlipCurve | None = None  # the timing fit's slip curve, estimated with the rewards
    own_intervals: np.ndarray | None = None  # (k, 2) the timing fit's sandwich intervals
    chooser: Chooser | None = None  # the timing model's player over continuous holds, for the fit check
    fit_check: FitCheck | None = None  # the fit check, where the fitter worked it out beside its other checks


def fit(
    demos: Demonstrations,
    options: FitOptions | None = None,
    /,
    *,
    progress: Progress | None = None,
    workers: int | None = None,
    stop: Callable[[], bool] | None = None,
    executor: Executor | None = None,
    **settings,
) -> FitResult:
    """Fit the state rewards that explain `demos` with `options` (or `FitOptions(**settings)`).

    Args:
        progress: called as progress(stage, done, total) as long work goes on: the lp's
            ``rounds`` (total None), the ``intervals`` LPs done, the bootstrap's ``resamples``.
        workers: processes for the bootstrap and for the people fit's candidate models (default: the cores);
            the answer is the same on any number.
        executor: where the bootstrap's refits run instead (`irl_core.support.executor`, e.g. a Dask
            cluster); the answer is the same.
        stop: asked at every LP iteration, every solve of maxent's soft Bellman equations
            and every progress report; once it says True the fit raises `Stopped` (a
            fitting thread whose answer is no longer wanted).

    Raises `BadInputError` (no demonstrated steps; `InfeasibleError` when the lp has no
    solution), `SolverError` or `Stopped`; ValueError for an unknown method (from `FitOptions`).
    """
    options = dataclasses.replace(options or FitOptions(), **settings) if settings else (options or FitOptions())
    if stop is not None:
        with stop_when(stop):
            return fit(demos, options, progress=_stopping(progress, stop), workers=workers, executor=executor)
    if demos.counts.sum() <= 0:
        raise BadInputError("the recordings contain no steps: there is nothing to fit", code="no_steps")
    start = time.perf_counter()
    keep_freed_memory()
    recorded_mdp = demos.mdp
    notes: list[Note] = []
    curve, demos = _on_its_curve(demos, options, notes)
    mdp = demos.mdp
    unknowns = build_unknowns(mdp, reward_cells=options.reward_cells, tie=options.tie)
    qmap = build_qmap(mdp, unknowns)
    if unknowns.k == 0:
        notes.append(Note("nothing_to_fit", "nothing to fit: every cell is ground, which {reward_cells=special} "
                                            "keeps at 0; try {reward_cells=all}"))
    try:
        fitted = _run(options.method, qmap, demos, options, progress=progress,
                      workers=workers or os.cpu_count() or 1)
    except InfeasibleError as exc:
        raise _infeasible(exc, qmap, demos, options) from exc
    if fitted.curve is not None:
        curve = fitted.curve
        demos = dataclasses.replace(demos, mdp=build_mdp(curve.world(recorded_mdp.world)))
    if curve is not None and not curve.known:
        how = "jointly with the rewards and the player" if fitted.curve is not None else "from the slips alone"
        notes.append(Note("slip_curve_fitted", curve.sentence().replace(": ", f" {how}: ", 1)))
    notes += fitted.notes

    bounds, kind = None, None
    if options.intervals and unknowns.k and fitted.player_model == "timing":
        bounds, kind = fitted.own_intervals, None if fitted.own_intervals is None else "confidence"
    elif options.intervals and unknowns.k:
        bounds, kind = _intervals(fitted, qmap, demos, options, notes, progress=progress, workers=workers,
                                  executor=executor)

    if unknowns.k:
        # Without intervals, the points stand for them: a catastrophe fitted no worse than the nuisance.
        spans = bounds if bounds is not None else np.column_stack([fitted.theta, fitted.theta])
        notes.extend(_not_separated(unknowns.symbols, spans, demos.mdp.world.terminal, intervals=bounds is not None))
    check = _fit_check(fitted, demos, options, notes)
    held = fitted.held_upper is not None and ~np.isnan(fitted.held_upper)  # named in their own note
    bounded = [label for j, (label, value) in enumerate(zip(unknowns.labels, fitted.theta))
               if at_bound(value, options.rmax) and not (held is not False and held[j])]
    if bounded:
        notes.append(Note("at_bound", f"at ±rmax: {', '.join(bounded)}; there the bound, not the demonstrations, "
                                      "set the value"))
    R_S = unknowns.state_rewards(fitted.theta)
    fitted_Q = recorded_mdp.reward_matrix(R_S) + recorded_mdp.gamma * recorded_mdp.expected_next(fitted.V)
    evaluation = evaluate(recorded_mdp, R_S, start=greedy_actions(fitted_Q))
    if options.cost == "unknown":
        fitted, bounds, R_S, demos = _in_seconds(fitted, bounds, R_S, demos)
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
        evaluation=evaluation,
        status=fitted.status,
        elapsed_s=time.perf_counter() - start,
        notes=notes,
        player_model=fitted.player_model,
        player=fitted.player,
        fit_check=check,
        rival_model=None if fitted.rival is None else fitted.rival.model.name,
        rival_theta=None if fitted.rival is None else np.asarray(fitted.rival.theta, dtype=float),
        slip_curve=curve,
        recorded_world=None if mdp is recorded_mdp else recorded_mdp.world,
    )


def _on_its_curve(demos: Demonstrations, options: FitOptions,
                  notes: list[Note]) -> tuple[SlipCurve | None, Demonstrations]:
    """On a time world: the slip curve the fit plans with (fitted to the recorded slips unless `slip_known`)
    and the demonstrations on that world (its cost per second 1 when the cost is unknown, so that rewards
    come out in seconds of holding). On a world with levels: (None, demos), or bad input for the time options."""
    world = demos.mdp.world
    if world.care != "time":
        for asked, flag in ((options.slip_known, "{slip_known}"), (options.cost == "unknown", "{cost=unknown}")):
            if asked:
                raise BadInputError(f"{flag} is for a time world, where care is how long the key is held; "
                                    f"{world.name!r} has levels, whose slips and costs the world states",
                                    code="time_option_on_levels")
        return None, demos
    if options.method in ("lp", "loss") and not options.slip_known:
        raise BadInputError(f"{{method={options.method}}} plans with a known slip curve and cannot learn one: on a "
                            "time world add {slip_known} to use the world's curve, or fit with {method=maxent} "
                            "(or auto), which learns it from the recorded slips", code="curve_needs_maxent")
    outcomes = demos.slip_outcomes
    if options.slip_known or outcomes.shape[0] == 0:
        curve = SlipCurve.of_world(world, observations=int(outcomes.shape[0]))
        if not options.slip_known:
            notes.append(Note("slip_curve_given", "no recorded holds to learn the slip curve from: the world's own "
                                                  "curve was used"))
    else:
        curve = fit_slip_curve(outcomes, max_hold_ms=world.max_hold_ms, confidence=options.confidence)
    if options.cost == "unknown":
        if not world.cost_per_second > 0:
            raise BadInputError("{cost=unknown} reports rewards in seconds of holding, which needs holding to cost "
                                f"something: {world.name!r} has cost_per_second 0", code="cost_is_zero")
        notes.append(Note("reward_in_seconds", "the cost of holding was taken as unknown: each reward is in seconds "
                                               "of holding (a reward of -14 is worth 14 s of care)"))
    if curve.known:
        return curve, demos
    return curve, dataclasses.replace(demos, mdp=build_mdp(curve.world(world)))


def _not_separated(symbols: tuple[str, ...], bounds: np.ndarray, terminal: tuple[str, ...], *,
                   intervals: bool) -> list[Note]:
    """A note when the lowest terminal symbol's interval (over its cells: the catastrophe) reaches a non-terminal
    one's (a nuisance): the data then do not tell the catastrophe from the nuisance, which is what care was to
    show. `bounds` (k, 2) are the intervals (`intervals`), or each point twice when there are none: the words
    then speak of the fitted rewards, whose span over a symbol's cells is no interval."""
    envelope: dict[str, tuple[float, float]] = {}
    for symbol, (low, high) in zip(symbols, np.asarray(bounds, dtype=float)):
        was = envelope.get(symbol, (np.inf, -np.inf))
        envelope[symbol] = (min(was[0], low), max(was[1], high))
    # The hazard: the terminal symbol with the lowest interval (the goal is terminal too); nuisances: every other.
    ends = sorted((s for s in envelope if s in terminal), key=lambda s: sum(envelope[s]))
    hazards = ends[:1]
    nuisances = [s for s in envelope if s not in terminal]
    pairs = [(h, n) for h in hazards for n in nuisances if envelope[h][1] >= envelope[n][0]]
    if not pairs:
        return []
    single = all(low == high for low, high in envelope.values())
    shown = (lambda s: f"{envelope[s][0]:.3g}") if single else (lambda s: f"{envelope[s][0]:.3g} to {envelope[s][1]:.3g}")
    said = "; ".join(f"{h} {shown(h)} {'is no lower than' if single else 'reaches'} {n} {shown(n)}" for h, n in pairs)
    what = ("the intervals do not separate the catastrophe from" if intervals
            else "the fitted rewards do not put the catastrophe below")
    return [Note("cliff_not_separated", f"{what} the nuisance ({said}): these recordings do not show which is worse")]


def _in_seconds(fitted: _Fitted, bounds: np.ndarray | None, R_S: np.ndarray,
                demos: Demonstrations) -> tuple[_Fitted, np.ndarray | None, np.ndarray, Demonstrations]:
    """A time world's fit in seconds of holding: the rewards, values and intervals divided by the cost per second,
    beta multiplied by it, on the same world at a cost of 1 per second (the same choices, the same likelihood: the
    data fix only rewards relative to the cost, and this is the world's cost taken as the unit)."""
    per_second = demos.mdp.world.cost_per_second
    player = fitted.player
    seconds = dataclasses.replace(
        fitted, theta=np.asarray(fitted.theta) / per_second, V=np.asarray(fitted.V) / per_second,
        beta=None if fitted.beta is None else fitted.beta * per_second,
        player=None if player is None else dataclasses.replace(player, beta=player.beta * per_second))
    world = demos.mdp.world.model_dump()
    world["cost_per_second"] = 1.0
    on_unit = dataclasses.replace(demos, mdp=build_mdp(type(demos.mdp.world).model_validate(world)))
    return seconds, None if bounds is None else bounds / per_second, R_S / per_second, on_unit


def _fit_check(fitted: _Fitted, demos: Demonstrations, options: FitOptions, notes: list[Note]) -> FitCheck | None:
    """A model of play's check against the recordings (`fit_check`), with a note; None for lp and loss."""
    if fitted.observed_policy is None:
        return None
    if demos.by_episode is None or demos.episode_facts is None:
        notes.append(Note("fit_check_not_run", "fit check not run: these demonstrations do not keep their episodes"))
        return None
    check = fitted.fit_check if fitted.fit_check is not None else fit_check(
        demos.mdp, fitted.observed_policy, demos.by_episode, demos.episode_facts, seed=options.seed,
        player=fitted.chooser)
    code = {True: "fit_check_passed", False: "fit_check_failed", None: "fit_check_not_run"}[check.passed]
    sentence = check.summary()
    if check.passed is False:
        sentence += "; read the rewards with care: the model does not explain how these recordings were played"
    notes.append(Note(code, sentence))
    return check


# A bound this many times rmax stands for "any bound": if the lp is infeasible there too, raising rmax cannot help.
LARGER_BOUND = 1000.0


def _infeasible(exc: InfeasibleError, qmap: QMap, demos: Demonstrations, options: FitOptions) -> InfeasibleError:
    """The lp's infeasibility, advising a larger rmax only where one would make the lp feasible."""
    try:
        solve_margin_lp(lp_constraints(qmap, demos.most_frequent, rmax=LARGER_BOUND * options.rmax), lam=0.0)
    except InfeasibleError:
        mixed = int(((demos.counts[demos.demonstrated] > 0).sum(axis=1) > 1).sum())
        why = (f"{mixed} demonstrated cells show more than one action (noisy play)" if mixed else
               "the most frequent actions contradict each other")
        return InfeasibleError(f"the demonstrations are not optimal for any reward, however large (none within "
                               f"±{LARGER_BOUND * options.rmax:g} either): {why}; fit noisy play with "
                               "{method=maxent} or {method=loss}", code="infeasible")
    return exc


def _stopping(progress: Progress | None, stop: Callable[[], bool]) -> Progress:
    """`progress` that first raises `Stopped` once `stop()` says so."""

    def heard(stage: str, done: int, total: int | None) -> None:
        if stop():
            raise Stopped()
        if progress is not None:
            progress(stage, done, total)

    return heard


def _run(method: str, qmap: QMap, demos: Demonstrations, options: FitOptions, *,
         progress: Progress | None = None, workers: int = 1) -> _Fitted:
    """Fit with `method`'s fitter (`options.method` is not read: auto runs another method with them), on up to
    `workers` processes where it has work side by side."""
    return fit_methods.method(method).load_fitter()(qmap, demos, options, progress=progress, workers=workers)


def auto_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                workers: int = 1) -> _Fitted:
    """The auto method's choice: the timing fit on a time world with recorded holds; else lp for a deterministic
    expert whose lp is feasible, else maxent (beta auto)."""
    if qmap.mdp.world.care == "time" and demos.hold_steps.shape[0] and options.player_model in (None, "timing"):
        fitted = _run("maxent", qmap, demos, dataclasses.replace(options, player_model="timing"), progress=progress,
                      workers=workers)
        fitted.notes.insert(0, Note("auto_chose", "method auto chose maxent with the timing model: on a time world "
                                                  "the exact holds show the care taken, and the slips the curve"))
        return fitted
    acted = demos.counts[demos.demonstrated]
    mixed = int(((acted > 0).sum(axis=1) > 1).sum())
    if mixed == 0:
        try:
            fitted = _run("lp", qmap, demos, options, progress=progress, workers=workers)
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
    fitted = _run("maxent", qmap, demos, dataclasses.replace(options, beta=beta), progress=progress, workers=workers)
    what = "beta estimated with the rewards" if beta == "auto" else f"beta {beta:g}"
    fitted.notes.insert(0, Note("auto_chose", f"method auto chose maxent ({what}): {why}"))
    return fitted


def lp_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
              workers: int = 1) -> _Fitted:
    """The simple IRL agent: the margin LP over the most frequent actions."""
    solution = solve_margin_lp(lp_constraints(qmap, demos.most_frequent, rmax=options.rmax), lam=options.lam,
                               progress=progress)
    theta, V = qmap.split(solution.x)
    fitted = _Fitted("lp", theta, V, status=solution.status, interior=solution.interior)
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
                workers: int = 1) -> _Fitted:
    """The loss IRL agent: the convex loss over the demonstrated action frequencies."""
    solution = fit_loss(qmap, demos.policy, rmax=options.rmax, lam=options.lam)
    theta, V = qmap.split(solution.x)
    return _Fitted("loss", theta, V, status="optimal_inaccurate" if solution.gap > STALL_TOLERANCE else "optimal",
                   notes=list(solution.notes), unique=solution.unique)


def maxent_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                  workers: int = 1) -> _Fitted:
    """Maximum-entropy IRL: the paper's Boltzmann expert with beta given or estimated (`FitOptions.maxent_beta`),
    or a model of people (`FitOptions.player_model`, `irl_core.irl.people_fit`)."""
    chosen_by_auto = options.method == "auto"
    model = options.maxent_player_model(chosen_by_auto=chosen_by_auto)
    timed = qmap.mdp.world.care == "time" and demos.hold_steps.shape[0] > 0
    if model == "timing" or (timed and options.player_model is None):
        return timing_fitter(qmap, demos, options, progress=progress)
    if model != "boltzmann":
        return _fit_people(qmap, demos, options, model=model, workers=workers)
    beta = options.maxent_beta(chosen_by_auto=chosen_by_auto)
    solution = fit_maxent(qmap.mdp, qmap.unknowns, demos.counts, beta=beta, rmax=options.rmax)
    plan = soft_bellman(qmap.mdp, qmap.unknowns.state_rewards(solution.theta), beta=solution.beta, V0=solution.V)
    return _Fitted("maxent", solution.theta, solution.V, beta=solution.beta, beta_auto=beta == "auto",
                   status="optimal" if solution.converged else "not_converged",
                   notes=_maxent_notes(solution, qmap.mdp, estimated=beta == "auto"), player_model="boltzmann",
                   player=Player(solution.beta), observed_policy=plan.policy)


# From this many states a people fit runs its candidates' default starts, the folds' refits and the held rewards'
# bounds on several processes (`workers`): on the 25-state mud world the pool's start took what it saved, on a
# 121-state cliff world it saved 17% of 2.5 s (two cores), on walled-24 2.5 s of 9.
PEOPLE_PARALLEL_STATES = 100


def _fit_people(qmap: QMap, demos: Demonstrations, options: FitOptions, *, model: str, workers: int = 1) -> _Fitted:
    """maxent with a model of people: the one given, or the one held-out episodes choose (``auto``), with a
    note saying which and why, and the other planning assumption kept as a rival where the data cannot tell
    whether the player plans for the hand (its intervals join the chosen model's)."""
    mdp, unknowns = qmap.mdp, qmap.unknowns
    if mdp.n_states < PEOPLE_PARALLEL_STATES:
        workers = 1
    notes: list[Note] = []
    rival = None
    hand = None
    if demos.calibration.shape[0]:
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
        rival = _planning_rival(choice)
        if rival is not None:
            notes.append(Note("planning_not_identified",
                              f"whether the player plans for the hand's noise is not told apart by the held-out "
                              f"episodes ({solution.model.name} and {rival.model.name} agree within their "
                              "noise): the reward's size depends on it, so the intervals cover both"))
    else:
        solution = fit_given_model(mdp, unknowns, demos.counts, model=player_model(model).with_hand(hand),
                                   rmax=options.rmax)
        notes.append(Note("player_model", f"player model {model}, as asked: {solution.model.summary}"))
    player = solution.player
    words = [f"beta {player.beta:.3g}"] + ([f"the hand's sigma {player.sigma:.2g} levels"]
                                           if solution.model.searches_hand else []) \
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
    flat, together = checks.flat, checks.together
    if flat.any():
        sides = [f"{label} {'at most' if side < 0 else 'at least'} {value:.3g}"
                 for label, value, side in zip(unknowns.labels, solution.theta, flat) if side]
        notes.append(Note("one_sided", "bounded on one side only (moving them to the bound, {rmax}, costs the "
                                       f"likelihood less than {FLAT_DROP:g}): " + "; ".join(sides)))
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
    return _Fitted("maxent", solution.theta, V, beta=player.beta, beta_auto=True,
                   status="optimal" if solution.converged else "not_converged", notes=notes,
                   player_model=solution.model.name, player=player, observed_policy=solution.plan.observed,
                   people=solution, rival=rival, held_upper=checks.held_upper,
                   together=together, fit_check=checks.fit_check)


def timing_fitter(qmap: QMap, demos: Demonstrations, options: FitOptions, *, progress: Progress | None,
                  workers: int = 1) -> _Fitted:
    """maxent with the timing model (`irl_core.irl.timing_fit`): rewards, slip curve and player from the exact
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
    return _Fitted("maxent", solution.theta, solution.plan.V, status="optimal" if solution.converged else
                   "not_converged", notes=notes, player_model="timing", player=player,
                   observed_policy=timing_policy(mdp, solution), curve=solution.curve,
                   chooser=timing_chooser(mdp, solution),
                   own_intervals=solution.theta_intervals)


def _planning_rival(choice: ModelChoice) -> PlayerFit | None:
    """The fit of the other planning assumption (``person`` or ``naive``) when held-out episodes cannot tell it
    from the chosen model, else None."""
    pair = {"person": "naive", "naive": "person"}
    other = pair.get(choice.name)
    if other is None or choice.held_out is None or other not in choice.held_out:
        return None
    assert choice.per_episode is not None
    if significantly_better(choice.per_episode[choice.name], choice.per_episode[other]):
        return None
    return choice.fits[other]


def _maxent_notes(solution: MaxEntSolution, mdp: MDP, *, estimated: bool) -> list[Note]:
    """Whether maxent converged, its beta (fixed or estimated) and whether the data fix beta."""
    notes = []
    if not solution.converged:
        notes.append(Note("not_converged", f"maxent stopped before converging: {solution.message.lower()}"))
    if not estimated:
        notes.append(Note("beta_fixed", f"beta fixed at {solution.beta:g}, not estimated ({{beta=auto}} estimates "
                                        "it from the data)"))
        return notes
    notes.append(Note("beta_estimated", f"beta estimated by maximum likelihood: {solution.beta:.3g}"))
    reason = identification(mdp)
    if solution.beta_at_bound:
        reason = (f"beta is not identified: the estimate ran to the end of its range ({solution.beta:.3g}); "
                  "the demonstrations do not fix the reward's scale")
    if reason:
        notes.append(Note("not_identified", reason))
    return notes


# Every method's fitter, checked against the registry.


def _intervals(fitted: _Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[Note], *,
               progress: Progress | None, workers: int | None,
               executor: Executor | None) -> tuple[np.ndarray | None, str | None]:
    """(k, 2) intervals and their kind (the method's), or (None, None) with a note why not."""
    kind = fit_methods.method(fitted.method).interval_kind
    if kind == "identified":
        bounds = _identified(fitted, qmap, demos, options, notes, progress=progress)
    else:
        bounds = _confidence(fitted, qmap, demos, options, notes, progress=progress, workers=workers,
                             executor=executor)
    return (None, None) if bounds is None else (bounds, kind)


def _identified(fitted: _Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[Note], *,
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


def _confidence(fitted: _Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions, notes: list[Note], *,
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
    if fitted.rival is not None:
        # The other planning assumption's interval is taken to have the same sampling spread about its own
        # estimate (a second bootstrap would double the time): the union covers both.
        shift = fitted.rival.theta - fitted.theta
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
    if episodes < 10:
        notes.append(Note("few_episodes", f"only {episodes} episodes: a bootstrap interval from so few is rough (it "
                                          "tends to be too narrow)"))
    return bounds


def _refit(fitted: _Fitted, qmap: QMap, demos: Demonstrations, options: FitOptions) -> Refitter:
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


def _moved(bounds: np.ndarray, fitted: _Fitted, qmap: QMap, options: FitOptions, notes: list[Note]) -> bool:
    """Whether the refits moved any unknown inside the bound (else the intervals measure nothing, with a note);
    a note names the ones they never moved."""
    inside = ~at_bound(bounds, options.rmax).any(axis=1)
    stayed = inside & (bounds[:, 1] - bounds[:, 0] <= 1e-9 * np.maximum(1.0, np.abs(bounds).max(axis=1)))
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
