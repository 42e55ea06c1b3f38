"""`fit`: one entry point for the inverse-RL methods in docs/fitting.md and docs/answers.md.

It builds the unknowns and the Q map once, runs the method's fitter (named by its entry in
`irl_core.irl.choices`; ``auto``'s chooses lp for a deterministic expert whose lp is
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

from irl_core.errors import CalibrationError
from irl_core.irl.choices import FITTED
from irl_core.irl.choices import method as method_entry
from irl_core.irl.evaluation import evaluate
from irl_core.irl.fit_check import FitCheck, fit_check
from irl_core.irl.fitters import Fitted, run_fitter
from irl_core.irl.identification import MOVE, Scale, decide_scale
from irl_core.irl.intervals.calibrated import widen
from irl_core.irl.intervals.honest import honest_intervals, honest_notes
from irl_core.irl.intervals.of_fit import fit_intervals
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.lp.solve import Progress, solve_margin_lp
from irl_core.irl.notes import Note
from irl_core.irl.options import FitOptions
from irl_core.irl.qmap import QMap, build_qmap, build_unknowns
from irl_core.irl.result import BadInputError, FitResult, InfeasibleError, at_bound
from irl_core.irl.timing.slip_curve import SlipCurve, fit_slip_curve
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.support.allocator import keep_freed_memory
from irl_core.support.executor import Executor
from irl_core.support.stopping import Stopped, stop_when
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import greedy_actions
from irl_core.worlds.world import World

# Fewer episodes than this and an interval is rough (a bootstrap's tends to be too narrow): said on every path.
FEW_EPISODES = 10
# `irl_core.METHODS`: the methods that fit (every one but the chooser).
METHODS = FITTED


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
    if options.calibration is not None and (why := options.calibration.mismatch(options, demos.mdp.world)):
        raise CalibrationError(f"the calibration does not fit this fit: {why}")
    start = time.perf_counter()
    keep_freed_memory()
    recorded_mdp = demos.mdp
    notes: list[Note] = []
    curve, demos = _on_its_curve(demos, options, notes)
    mdp = demos.mdp
    given_beta = float(options.beta) if isinstance(options.beta, int | float) and \
        method_entry(options.method).uses_beta else None
    scale = decide_scale(mdp.world, options.known, reward_cells=options.reward_cells, rmax=options.rmax,
                         given_beta=given_beta)
    notes.extend(_scale_notes(scale))
    if scale.move:  # a move's cost becomes an unknown reward at every non-terminal state (`qmap`)
        mdp = recorded_mdp = dataclasses.replace(mdp, R_A=np.zeros_like(mdp.R_A))
        demos = dataclasses.replace(demos, mdp=mdp)
    unknowns = build_unknowns(mdp, reward_cells=options.reward_cells, tie=options.tie, held=scale.held,
                              move=scale.move)
    qmap = build_qmap(mdp, unknowns)
    if unknowns.k == 0:
        notes.append(Note("nothing_to_fit", "nothing to fit: every cell is ground, which {reward_cells=special} "
                                            "keeps at 0; try {reward_cells=all}"))
    try:
        fitted = run_fitter(options.method, qmap, demos, options, progress=progress,
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
        bounds, kind = fit_intervals(fitted, qmap, demos, options, notes, progress=progress, workers=workers,
                                  executor=executor)

    honest = None
    if bounds is not None:
        honest = honest_intervals(fitted.theta, bounds, flat=fitted.flat, rmax=options.rmax)
        if options.calibration is not None:
            # Widened after the invariants: around the point they hold, so it stays inside and an end at ±rmax
            # stays there (the one-sided note then reads the widened end).
            honest = dataclasses.replace(honest, bounds=widen(fitted.theta, honest.bounds, unknowns.symbols,
                                                              options.calibration, rmax=options.rmax))
            notes.append(_calibrated_note(options, demos.episodes))
        bounds = honest.bounds
    notes.extend(honest_notes(unknowns.labels, fitted.theta, honest, flat=fitted.flat, rmax=options.rmax))
    if bounds is not None and demos.episodes < FEW_EPISODES:
        notes.append(Note("few_episodes", f"only {demos.episodes} episodes: " + (
            "a confidence interval from so few is rough (it tends to be too narrow)" if kind == "confidence" else
            "the identified set takes the most frequent action at each cell as the expert's choice, which so few "
            "may not show")))
    if unknowns.k:
        # Without intervals, the points stand for them: a catastrophe fitted no worse than the nuisance.
        spans = bounds if bounds is not None else np.column_stack([fitted.theta, fitted.theta])
        hazards = _hazards(unknowns.symbols, fitted.theta, demos.mdp.world)
        notes.extend(_not_separated(unknowns.symbols, spans, hazards, demos.mdp.world.terminal,
                                    intervals=bounds is not None))
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
        interval_method=None if bounds is None else _interval_method(kind, fitted, demos, options),
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
        scale=scale,
    )


def _interval_method(kind: str | None, fitted: Fitted, demos: Demonstrations, options: FitOptions) -> str:
    """How the intervals were made (the JSON's ``interval_method``): ``identified``, ``bootstrap``, ``two-level
    bootstrap`` (a study's pool: participants, then their episodes) or ``sandwich`` (the timing model), then
    ``+union`` where they join a rival planning model's and ``+calibrated`` where a calibration widened them."""
    if kind == "identified":
        method = "identified"
    elif fitted.player_model == "timing":
        method = "sandwich"
    else:
        method = "bootstrap" if demos.episode_groups is None else "two-level bootstrap"
    if (fitted.rival is not None or fitted.close) and kind != "identified":
        method += "+union"
    return method + ("+calibrated" if options.calibration is not None else "")


def _calibrated_note(options: FitOptions, episodes: int) -> Note:
    """What the calibration did to the intervals, and the design it was learned on."""
    calibration = options.calibration
    assert calibration is not None
    scales = ", ".join(f"{symbol} x{scale:.3g}" if scale is not None else f"{symbol} the whole range"
                       for symbol, scale in calibration.scales)
    design = "" if episodes == calibration.episodes else (
        f"; it was learned on {calibration.episodes} episodes, these are {episodes}, so it may be too wide or "
        "too narrow for them")
    return Note("calibrated", f"intervals calibrated by careful check ({calibration.datasets} datasets of each of "
                              f"{', '.join(calibration.players)}): each half-width around its point widened "
                              f"{scales}, so that they held the truth in at least {calibration.confidence:.0%} of "
                              f"those datasets{design}")


def _scale_notes(scale: Scale) -> list[Note]:
    """What fixes the rewards' units, where the world's care cost does not (`identification`)."""
    if scale.reference is not None:
        return [Note("scale_not_identified",
                     f"nothing fixes the rewards' units ({scale.unfixed_why}), so the recordings show only their "
                     f"ratios: each reward is read relative to {scale.reference}, held at 1 (give "
                     f"{{known={scale.reference}=100}} to put them in points)" + (
                         "; a move's cost is one more unknown (move), as a reward relative to "
                         f"{scale.reference}" if scale.move else ""))]
    if scale.beta is not None:
        return [Note("units_from_beta", f"nothing in the world fixes the rewards' units ({scale.unfixed_why}): they "
                                        f"come from the {{beta={scale.beta:g}}} given, since play shows only beta "
                                        "times the rewards")]
    if scale.held:
        held = ", ".join(f"{symbol} {value:g}" for symbol, value in scale.held)
        return [Note("rewards_held", f"held at the values given, not fitted: {held}")]
    return []


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


def _hazards(symbols: tuple[str, ...], theta: np.ndarray, world: World) -> set[str]:
    """The terminal symbols that are hazards: below zero in the world file, or fitted below zero."""
    fitted_below = {symbol for symbol, value in zip(symbols, theta) if value < 0}
    return {symbol for symbol in world.terminal if world.rewards.get(symbol, 0.0) < 0 or symbol in fitted_below}


def _not_separated(symbols: tuple[str, ...], bounds: np.ndarray, hazards: set[str], terminal: tuple[str, ...], *,
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
    # Only a hazard that ends episodes is a catastrophe: a world whose one terminal cell is the goal has none.
    lowest = [s for s in ends[:1] if s in hazards]
    nuisances = [s for s in envelope if s not in terminal and s != MOVE]  # a move's cost is no cell
    pairs = [(h, n) for h in lowest for n in nuisances if envelope[h][1] >= envelope[n][0]]
    if not pairs:
        return []
    single = all(low == high for low, high in envelope.values())
    shown = (lambda s: f"{envelope[s][0]:.3g}") if single else (lambda s: f"{envelope[s][0]:.3g} to {envelope[s][1]:.3g}")
    said = "; ".join(f"{h} {shown(h)} {'is no lower than' if single else 'reaches'} {n} {shown(n)}" for h, n in pairs)
    what = ("the intervals do not separate the catastrophe from" if intervals
            else "the fitted rewards do not put the catastrophe below")
    return [Note("cliff_not_separated", f"{what} the nuisance ({said}): these recordings do not show which is worse")]


def _in_seconds(fitted: Fitted, bounds: np.ndarray | None, R_S: np.ndarray,
                demos: Demonstrations) -> tuple[Fitted, np.ndarray | None, np.ndarray, Demonstrations]:
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


def _fit_check(fitted: Fitted, demos: Demonstrations, options: FitOptions, notes: list[Note]) -> FitCheck | None:
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

    def stop_or_report(stage: str, done: int, total: int | None) -> None:
        if stop():
            raise Stopped()
        if progress is not None:
            progress(stage, done, total)

    return stop_or_report






