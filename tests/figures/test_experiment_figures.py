"""The experiment's figures are drawn by what they hold: intervals, rewards or a policy."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.patches import Rectangle

from careful_tui.render.figures.board import Board
from careful_tui.render.figures.experiment_figures import draw_experiment_figure, policy_panel
from irl_core.experiment.run import ExperimentResult, Figure, Separation
from irl_core.worlds.world import BUILTIN_WORLDS


@pytest.fixture
def result():
    mud, paper = BUILTIN_WORLDS["mud"], BUILTIN_WORLDS["paper"]
    fitted = Board.for_world(mud).rewards(mud)
    fitted[3, 1:5] = -800.0
    return ExperimentResult(
        figures=[
            Figure("fig3-optimal-policy", "optimal policy", paper,
                   policy={(0, 0): ("right", 2), (2, 0): ("up", 3), (3, 0): ("up", 8)}),
            Figure("fig4-true-reward", "true reward", paper, values=Board.for_world(paper).rewards(paper)),
            Figure("intervals-mud", "intervals on mud", mud, values=fitted),
        ],
        separations=[Separation("mud", cliff=(-1000.0, -661.2), mud=(-49.3, -14.8), seconds=0.1)],
    )


def test_a_world_with_interval_results_gets_the_interval_plot(result):
    drawn = draw_experiment_figure(result.figures[2], result, rmax=1000.0)
    ax = drawn.axes[0]
    assert ax.get_xscale() == "symlog"
    bars = sorted((p for p in ax.patches if isinstance(p, Rectangle)), key=lambda p: p.get_y())
    ends = [end for bar in bars for end in (bar.get_x(), bar.get_x() + bar.get_width())]
    assert ends == pytest.approx([-1000.0, -661.2, -49.3, -14.8])
    assert [t.get_text() for t in ax.get_yticklabels()] == ["cliff", "mud"]
    # The estimate dots: the mean fitted value over each symbol's cells.
    dots = [line.get_xdata()[0] for line in ax.lines if line.get_marker() == "o"]
    assert dots == pytest.approx([-800.0, -30.0])


def test_reward_figures_share_one_colour_scale(result):
    result.figures[2].values[3, 1] = -4321.0  # an interval figure's values do not stretch the heatmaps' scale
    drawn = draw_experiment_figure(result.figures[1], result, rmax=1000.0)
    norm = drawn.axes[0].images[0].norm
    assert (norm.vmin, norm.vmax) == (-1000.0, 1000.0)


def test_policy_labels_become_arrows(result):
    figure = result.figures[0]
    panel = policy_panel(figure, Board.for_world(figure.world))
    assert panel.direction[0, 0] == 1 and panel.carefulness[0, 0] == 2
    assert panel.direction[3, 0] == 0 and panel.carefulness[3, 0] == 8
    assert (panel.direction == -1).sum() == panel.direction.size - 3
    assert np.all(panel.carefulness[panel.direction == -1] == 1)


def test_other_figures_of_that_world_stay_heatmaps(result):
    mud_fit = Figure("mud-fit", "a fit of mud", BUILTIN_WORLDS["mud"], values=result.figures[2].values)
    drawn = draw_experiment_figure(mud_fit, result, rmax=1000.0)
    assert drawn.axes[0].images and drawn.axes[0].get_xscale() == "linear"
