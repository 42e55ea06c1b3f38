"""The experiment's figures (`irl_core.experiment.run.Figure`) drawn for a paper.

What a figure holds decides how it is drawn, so new stages need no new code here:
- an `intervals-...` figure: the interval plot of the interval result added with it to
  `ExperimentResult.separations` (cliff and mud rows, the figure's values as the estimates,
  labelled identified set or confidence interval as the result's `kind` says);
- a figure with values: a reward heatmap, on one colour scale shared by every figure of the
  run, so the same colour is the same reward in figure 4 (true) and figures 5, 6 and 8 (fitted);
- a figure with a policy (an action per cell): arrows sized by carefulness.
Each is one panel a third of a page wide, without a title (the paper's caption is the title).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure as PlotFigure

from careful_tui.render.figures.board import Board
from careful_tui.render.figures.heatmap import reward_figure, reward_limit
from careful_tui.render.figures.intervals import IntervalRow, interval_figure
from careful_tui.render.figures.policy import PolicyPanel, policy_figure
from careful_tui.render.figures.style import symbol_label
from irl_core.experiment.run import NOISY_CONFIDENCE, ExperimentResult, Figure, Separation
from irl_core.worlds.mdp import DIRECTIONS


def draw_experiment_figure(figure: Figure, result: ExperimentResult, *, rmax: float) -> PlotFigure:
    """The paper figure for one of the experiment's figures (see the module docstring).

    Args:
        rmax: the bound the experiment's lp fits used: an identified set's axis runs to it.
    """
    board = Board.for_world(figure.world)
    separation = interval_result(figure, result)
    if separation is not None:
        rows = separation_rows(separation, figure, board)
        bound = separation.rmax if separation.rmax is not None else rmax
        if separation.kind == "confidence":
            return interval_figure([("", rows)], kind="confidence", confidence=NOISY_CONFIDENCE, rmax=bound)
        return interval_figure([("", rows)], kind=separation.kind, rmax=bound)
    if figure.values is not None:
        return reward_figure([("", figure.values)], board, vmax=shared_scale(result))
    return policy_figure([policy_panel(figure, board)], board, levels=figure.world.levels,
                         background=board.rewards(figure.world), vmax=shared_scale(result))


def interval_result(figure: Figure, result: ExperimentResult) -> Separation | None:
    """The interval results an `intervals-...` figure shows, or None for any other figure.

    The experiment adds one `intervals-...` figure with each of its interval results, in the same
    order, so the k-th such figure shows the k-th result (of the figure's own world).
    """
    keyed = [f.key for f in result.figures if f.key.startswith("intervals-") and f.values is not None]
    if figure.key not in keyed or len(keyed) != len(result.separations):
        return None
    separation = result.separations[keyed.index(figure.key)]
    return separation if separation.world == figure.world.name else None


def shared_scale(result: ExperimentResult) -> float:
    """One colour-scale end for every reward figure of a run: the largest |reward| any of them shows.

    Interval figures are not heatmaps, so their values (whose fits may use another bound) do not count.
    """
    heatmaps = [f for f in result.figures if interval_result(f, result) is None]
    grids = [f.values for f in heatmaps if f.values is not None]
    grids += [Board.for_world(f.world).rewards(f.world) for f in heatmaps]
    return reward_limit(*grids)


def separation_rows(separation: Separation, figure: Figure, board: Board) -> list[IntervalRow]:
    """Cliff and mud rows: the interval hull of their cells, the mean fitted value, the world's value."""
    if figure.values is None:
        raise ValueError(f"figure {figure.key} has no values to set its interval rows against")
    rows = []
    for symbol, (low, high) in (("C", separation.cliff), ("U", separation.mud)):
        cells = board.symbols == symbol
        rows.append(IntervalRow(symbol_label(symbol), symbol, low, high,
                                float(np.nanmean(figure.values[cells])), figure.world.reward_of(symbol)))
    return rows


def policy_panel(figure: Figure, board: Board) -> PolicyPanel:
    """A policy panel from a figure's actions (direction, carefulness level) per cell."""
    direction = np.full(board.shape, -1)
    carefulness = np.ones(board.shape, dtype=int)
    for (r, c), (name, level) in figure.policy.items():
        direction[r, c] = DIRECTIONS.index(name)
        carefulness[r, c] = level
    return PolicyPanel("", direction, carefulness)
