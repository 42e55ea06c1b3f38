"""Every figure kind against a stored baseline image, and the data each one draws."""

from __future__ import annotations

import numpy as np
import pytest

from careful_tui.render.figures.board import Board
from careful_tui.render.figures.carefulness import CarefulnessByDistance, carefulness_by_distance, draw_carefulness
from careful_tui.render.figures.heatmap import (
    add_colour_bar,
    draw_reward,
    reward_figure,
    reward_limit,
    reward_norm,
    symlog_ticks,
    value_label,
)
from careful_tui.render.figures.intervals import IntervalRow, interval_figure, kind_label, worst_first
from careful_tui.render.figures.policy import PolicyPanel, policy_figure
from careful_tui.render.figures.style import PANEL_WIDTH, figure_style, new_figure
from irl_core.worlds.world import BUILTIN_WORLDS

# The optimal policy of `paper` (up, right, down, left = 0..3; -1 at terminal cells) and its levels.
PAPER_OPTIMAL_DIRECTION = np.array([[1, 1, 1, 1, 1, 2], [1, 1, 1, 1, 1, 2], [0, 1, 1, 1, 1, 2], [0, -1, -1, -1, -1, -1]])
PAPER_OPTIMAL_LEVEL = np.array([[2, 2, 2, 2, 2, 3], [3, 3, 3, 3, 3, 3], [3, 8, 8, 8, 8, 4], [8, 1, 1, 1, 1, 1]])

MUD_ROWS = [
    IntervalRow("cliff (3, 1)", "C", -1000.0, -661.2, -1000.0, -1000.0),
    IntervalRow("cliff (3, 2)", "C", -1000.0, -702.5, -946.2, -1000.0),
    IntervalRow("mud (1, 1)", "U", -49.3, -14.8, -23.9, -30.0),
    IntervalRow("mud (1, 2)", "U", -45.0, -20.1, -31.0, -30.0),
    IntervalRow("goal (3, 5)", "G", 89.7, 1000.0, 104.6, 100.0),
]
MUD_SIMPLE_ROWS = [
    IntervalRow("cliff", "C", -1000.0, 51.0, -1000.0, -1000.0),
    IntervalRow("mud", "U", -98.0, 60.2, 33.0, -30.0),
]


def test_reward_heatmap_fitted_beside_true(matches_baseline, mud_world, mud_fitted):
    board = Board.for_world(mud_world)
    figure = reward_figure([("fitted", mud_fitted), ("true", board.rewards(mud_world))], board)
    matches_baseline(figure, "reward-fitted-true")


def test_policy_demonstrated_beside_optimal(matches_baseline):
    world = BUILTIN_WORLDS["paper"]
    board = Board.for_world(world)
    count = np.array([[5, 1, 2, 9, 12, 14], [0, 0, 0, 20, 31, 38], [3, 14, 22, 30, 36, 40], [0, 0, 0, 0, 0, 0]])
    demonstrated = PolicyPanel("demonstrated", np.where(count > 0, PAPER_OPTIMAL_DIRECTION, -1),
                               np.minimum(PAPER_OPTIMAL_LEVEL + 1, 14), count)
    optimal = PolicyPanel("optimal", PAPER_OPTIMAL_DIRECTION, PAPER_OPTIMAL_LEVEL)
    figure = policy_figure([demonstrated, optimal], board, levels=14, background=board.rewards(world))
    matches_baseline(figure, "policy-demonstrated-optimal")


def test_intervals_identified_and_confidence(matches_baseline):
    matches_baseline(interval_figure([("mud", MUD_ROWS), ("mud-simple", MUD_SIMPLE_ROWS)],
                                     kind="identified", rmax=1000.0), "intervals-identified")
    matches_baseline(interval_figure([("", MUD_SIMPLE_ROWS)], kind="confidence", confidence=0.9, rmax=1000.0),
                     "intervals-confidence")


def test_carefulness_by_distance(matches_baseline):
    human = CarefulnessByDistance(np.array([1, 2, 3, 4]), np.array([6.4, 4.8, 3.8, 3.1]),
                                  np.array([1.6, 0.6, 0.8, 1.0]), np.array([17, 20, 17, 5]))
    expert = CarefulnessByDistance(np.array([1, 2, 3, 4]), np.array([5.9, 3.0, 2.3, 2.0]),
                                   np.array([0.2, 0.05, 0.05, 0.0]), np.array([180, 120, 60, 20]))
    with figure_style():  # one panel of its own, as the study's and the fit's figures draw it among others
        figure = new_figure(PANEL_WIDTH, PANEL_WIDTH * 0.75)
        draw_carefulness(figure.subplots(), [("person", human), ("optimal expert", expert)], levels=14)
    matches_baseline(figure, "carefulness-by-distance")


def test_a_changed_value_fails_the_baseline(matches_baseline, mud_world, mud_fitted):
    """The tolerance is tight enough to catch one cell's value changing (-946 to -94.6)."""
    board = Board.for_world(mud_world)
    mud_fitted[3, 2] = -94.6
    figure = reward_figure([("fitted", mud_fitted), ("true", board.rewards(mud_world))], board)
    with pytest.raises(AssertionError, match="did not match"):
        matches_baseline(figure, "reward-fitted-true", may_update=False)


def rendered(figure) -> np.ndarray:
    """(H, W, 3) uint8 pixels of a figure drawn by Agg."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].astype(int)


def pixel(pixels: np.ndarray, figure, xy_display: tuple[float, float]) -> np.ndarray:
    x, y = xy_display
    return pixels[int(round(figure.bbox.height - y)), int(round(x))]


def test_the_cliff_cell_has_the_colour_bars_colour_for_minus_1000(mud_world, mud_fitted):
    board = Board.for_world(mud_world)
    with figure_style():
        figure = new_figure(3.0, 2.0)
        ax = figure.subplots()
        norm = reward_norm(reward_limit(mud_fitted))
        image = draw_reward(ax, mud_fitted, board, norm=norm, width=10.0)  # too small for text
        add_colour_bar(figure, image, [ax], vmax=norm.vmax)
    pixels = rendered(figure)
    bar = figure.axes[1]
    cliff = pixel(pixels, figure, ax.transData.transform((1, 3)))  # cell (3, 1): -1000
    # The bar's -1000 end, two pixels inside its bottom edge.
    x, y = bar.transData.transform((0.5, -1000.0))
    at_minus_1000 = pixel(pixels, figure, (x, y + 2))
    at_minus_100 = pixel(pixels, figure, bar.transData.transform((0.5, -100.0)))
    assert np.abs(cliff - at_minus_1000).max() <= 6
    assert np.abs(cliff - at_minus_100).max() > 40
    mud = pixel(pixels, figure, ax.transData.transform((1, 1)))  # cell (1, 1): -23.9
    assert np.abs(mud - pixel(pixels, figure, bar.transData.transform((0.5, -23.9)))).max() <= 6


def test_colour_scale_is_symmetric_log_centred_on_zero():
    norm = reward_norm(1000.0)
    assert norm(0.0) == pytest.approx(0.5)
    assert norm(-1000.0) == pytest.approx(0.0) and norm(1000.0) == pytest.approx(1.0)
    # Each power of ten beyond the linear part takes the same share of the bar.
    assert norm(-100.0) - norm(-1000.0) == pytest.approx(norm(-10.0) - norm(-100.0))
    assert symlog_ticks(1000.0) == [-1000, -100, -10, 0, 10, 100, 1000]
    assert symlog_ticks(2000.0) == [-2000, -1000, -100, -10, 0, 10, 100, 1000, 2000]
    assert symlog_ticks(2000.0, ends=False) == [-1000, -100, -10, 0, 10, 100, 1000]
    assert reward_limit(np.array([-30.0, 100.0, np.nan])) == 100.0
    assert reward_limit(np.array([-1565.3, 2.0])) == 2000.0


def test_cell_values_read_cleanly():
    assert [value_label(v) for v in (-1000.0, -31.04, -1e-12, 0.0, 104.6)] == ["−1000", "−31.0", "0", "0", "105"]


def test_rows_put_each_symbol_together_worst_first():
    order = worst_first([MUD_ROWS[4], MUD_ROWS[2], MUD_ROWS[0], MUD_ROWS[3], MUD_ROWS[1]])
    assert [row.symbol for row in order] == ["C", "C", "U", "U", "G"]


def test_interval_kinds_are_named():
    assert kind_label("identified") == "identified by the demonstrations"
    assert kind_label("confidence", 0.95) == "95% confidence interval"
    with pytest.raises(ValueError):
        kind_label("confidence")
    with pytest.raises(ValueError):
        kind_label("bayesian", 0.9)


def test_carefulness_by_distance_from_counts_by_hand():
    # Three states at distances 1, 1, 2 (and one unreachable); L = 2, so actions 0..7 alternate levels 1, 2.
    counts = np.zeros((4, 8))
    counts[0, 1] = 3  # level 2, three times
    counts[1, 0] = 1  # level 1, once
    counts[2, 4] = 2  # level 1, twice
    counts[3, 1] = 9  # unreachable: left out
    data = carefulness_by_distance(counts, np.array([1, 1, 2, -1]), levels=2)
    assert data.distance.tolist() == [1, 2]
    assert data.steps.tolist() == [4, 2]
    assert data.mean.tolist() == pytest.approx([1.75, 1.0])
    # Levels 2, 2, 2, 1: sample variance 0.25, standard error 0.25, half-width 1.96 * 0.25.
    assert data.half_width[0] == pytest.approx(1.959964 * 0.25)
    assert data.half_width[1] == pytest.approx(0.0)
