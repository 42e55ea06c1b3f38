"""The figures of a study's report (`careful study report`), named as the files they become.

Per world ``w<i>-<world>``:
- ``rewards-...``: the fitted reward (point estimate) of each participant as small multiples, beside the
  world file's reward and the pooled fit, on one colour scale;
- ``carefulness-...``: mean carefulness against distance to danger (on a time world the geometric
  mean hold), a panel per participant, everyone pooled as the faint reference line.
And ``intervals-pooled``: the pooled fit's interval per symbol, a panel per world, labelled with
the kind of interval (one file per kind when worlds differ: ``intervals-pooled-identified``).
"""

from __future__ import annotations

from matplotlib.figure import Figure

from careful_tui.render.figures.board import Board
from careful_tui.render.figures.carefulness import (
    CarefulnessByDistance,
    HoldsByDistance,
    carefulness_by_distance,
    holds_by_distance,
    state_distances,
)
from careful_tui.render.figures.intervals import IntervalRow, interval_figure
from careful_tui.render.figures.small_multiples import carefulness_multiples, reward_multiples
from careful_tui.render.figures.style import plain, symbol_label
from irl_core.recordings.writer import slug
from irl_core.studies.report import POOLED, CellFit, StudyData
from irl_core.support.plural import plural


def world_key(data: StudyData, world_index: int) -> str:
    """``w0-paper``: the world's index in the study file and its name, as a file-name piece."""
    return f"w{world_index}-{slug(data.study.grid_worlds[world_index].name, default='world')}"


def method_phrase(fits: list[CellFit]) -> str:
    """How the fits were made, from the fits themselves: "maxent, beta estimated", "lp and maxent"."""
    methods = sorted({f.method for f in fits if not f.error})
    text = " and ".join(methods) or "no fit"
    if any(f.beta_auto for f in fits):
        text += ", beta estimated"
    return text


def report_figures(data: StudyData, fits: list[CellFit]) -> list[tuple[str, Figure]]:
    """(file name without suffix, figure) for every figure of the report."""
    figures = []
    for world_index, world in enumerate(data.study.grid_worlds):
        mine = [(cell, fit) for cell, fit in zip(data.cells, fits) if cell.world_index == world_index]
        board = Board.for_world(world)
        key = world_key(data, world_index)
        name = plain(world.name)
        panels = [("true (world file)", board.rewards(world))] if world.rewards else []
        panels += [(_who(cell, fit), fit.reward_grid) for cell, fit in mine if fit.reward_grid is not None]
        if panels:
            how = method_phrase([f for _, f in mine])
            title = f"{name}: fitted reward per participant, point estimates ({how}, one value per symbol)"
            figures.append((f"rewards-{key}", reward_multiples(panels, board, title=title)))
        played = [(cell, cell.demos) for cell, _ in mine if cell.demos is not None]
        if world.levels > 1 and played:
            distances = state_distances(played[0][1].mdp)
            series: dict[str, CarefulnessByDistance | HoldsByDistance] = {
                cell.participant: holds_by_distance(demos.hold_steps, distances) if world.care == "time" else
                carefulness_by_distance(demos.counts, distances, levels=world.levels) for cell, demos in played}
            pool = next((cell for cell, _ in played if cell.participant == POOLED), None)
            reference = (f"everyone pooled ({pool.participants})", series.pop(POOLED)) if pool else None
            if series:
                what = "hold" if world.care == "time" else "carefulness"
                title = f"{name}: {what} by distance to danger, per participant (main episodes)"
                figures.append((f"carefulness-{key}", carefulness_multiples(
                    [(plain(who), line) for who, line in series.items()], levels=world.levels, reference=reference,
                    title=title)))
    figures += _pooled_interval_figures(data, fits)
    return figures


def _who(cell, fit: CellFit) -> str:
    if cell.participant != POOLED:
        return plain(cell.participant)
    return f"population ({fit.pooled})" if fit.pooled is not None else f"pooled ({cell.participants})"


def _pooled_interval_figures(data: StudyData, fits: list[CellFit]) -> list[tuple[str, Figure]]:
    by_kind: dict[str, list[tuple[str, list[IntervalRow]]]] = {}
    confidence = None
    for cell, fit in zip(data.cells, fits):
        if cell.participant != POOLED or fit.intervals is None or fit.interval_kind is None:
            continue
        rows = [IntervalRow(symbol_label(symbol), symbol, float(low), float(high),
                            float(estimate), float(truth))
                for symbol, (low, high), estimate, truth in zip(fit.symbols, fit.intervals, fit.estimate, fit.truth)]
        world = data.study.grid_worlds[cell.world_index]
        title = (f"{plain(world.name)}: the population of {plural(fit.pooled, 'participant')}" if fit.pooled is not None
                 else f"{plain(world.name)}: pooled over {plural(cell.participants, 'participant')}, "
                      f"{plural(cell.episodes, 'episode')}")
        by_kind.setdefault(fit.interval_kind, []).append((title, rows))
        if fit.interval_kind == "confidence":
            confidence = fit.confidence
    figures = []
    for kind, panels in by_kind.items():
        name = "intervals-pooled" if len(by_kind) == 1 else f"intervals-pooled-{kind}"
        # A confidence interval's axis follows the values; an identified set's runs to the fits' ±rmax.
        rmax = None if kind == "confidence" else next(f.rmax for f in fits if f.interval_kind == kind)
        figures.append((name, interval_figure(panels, kind=kind, confidence=confidence, rmax=rmax,
                                              width=3.2)))
    return figures
