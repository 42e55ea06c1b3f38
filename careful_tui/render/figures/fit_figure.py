"""One `careful fit` result as one figure: what `careful fit --figure PATH` writes.

First row: the fitted reward, and the world's own reward beside it on the same colour scale
(when the world file gives rewards). Second row: the demonstrated policy and, with carefulness
levels, mean carefulness against distance to danger. On a time world, a row with the slip curve
over the recorded slips and the holds against distance to danger (`careful_tui.render.figures.timing`).
With intervals, a last row: the interval of every unknown (or of every symbol, when there are too many
cells to read).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from careful_tui.render.figures.board import Board
from careful_tui.render.figures.carefulness import carefulness_by_distance, draw_carefulness, state_distances
from careful_tui.render.figures.heatmap import (
    COLOUR_BAR_WIDTH,
    TITLE_HEIGHT,
    add_colour_bar,
    cell_width,
    draw_reward,
    reward_limit,
    reward_norm,
    value_label,
)
from careful_tui.render.figures.intervals import (
    FRAME_HEIGHT,
    LEGEND_HEIGHT,
    ROW_HEIGHT,
    IntervalRow,
    draw_intervals,
    interval_legend,
    worst_first,
)
from careful_tui.render.figures.policy import NOTE_HEIGHT, draw_policy, policy_note, policy_panel
from careful_tui.render.figures.style import PAGE_WIDTH, figure_style, new_figure, symbol_label
from careful_tui.render.figures.timing import draw_holds, draw_slip_curve
from careful_tui.render.intervals import interval_title, shown_reward_grid
from irl_core.irl import FitResult
from irl_core.irl.identification import MOVE
from irl_core.irl.intervals.honest import one_sided
from irl_core.support.plural import plural

# Above this many unknowns the interval plot shows one row per symbol (the hull of its cells).
MAX_INTERVAL_ROWS = 24
# A time world's row: the slip curve and the holds by distance (inches).
TIMING_HEIGHT = 2.3


def interval_rows(result: FitResult) -> tuple[list[IntervalRow], bool]:
    """A row per unknown ("cliff (3, 1)", or "cliff" when tied), or per symbol when there are many.

    Returns the rows and whether they are per-symbol hulls of several unknowns (none without intervals).
    """
    if result.intervals is None:
        return [], False
    intervals = result.intervals
    sides = one_sided(np.asarray(intervals), float(result.rmax))
    truth = result.true_theta() if result.world.rewards else np.full(len(result.labels), np.nan)
    first_state = np.asarray(result.unknowns.basis.argmax(axis=0)).ravel()
    rows = []
    for j, symbol in enumerate(result.unknowns.symbols):
        name = symbol_label(symbol)
        label = name if result.options.tie or symbol == MOVE else f"{name} {result.mdp.cells[first_state[j]]}"
        low, high = (float(v) for v in intervals[j])
        # A reward bounded on one side only is its bound: no point is drawn as its estimate.
        estimate = float("nan") if sides[j] else float(result.theta[j])
        rows.append(IntervalRow(label, symbol, low, high, estimate, float(truth[j])))
    if len(rows) <= MAX_INTERVAL_ROWS:
        return rows, False
    hulls = []
    for symbol in dict.fromkeys(row.symbol for row in rows):
        mine = [row for row in rows if row.symbol == symbol]
        truths = {row.truth for row in mine}
        hulls.append(IntervalRow(f"{symbol_label(symbol)} ({plural(len(mine), 'cell')})", symbol,
                                 min(r.low for r in mine), max(r.high for r in mine),
                                 _mean_estimate([r.estimate for r in mine]),
                                 truths.pop() if len(truths) == 1 else float("nan")))
    return hulls, True


def _mean_estimate(estimates: list[float]) -> float:
    """The mean of the estimates there are (NaN: none, every unknown bounded on one side only)."""
    finite = [e for e in estimates if np.isfinite(e)]
    return float(np.mean(finite)) if finite else float("nan")


def fitted_cells(result: FitResult) -> str:
    """Which cells the fit estimated: "ground fixed at 0", "every cell fitted; one value per symbol"."""
    options = result.options
    cells = "every cell fitted" if options.reward_cells == "all" else "ground fixed at 0"
    return f"{cells}{'; one value per symbol' if options.tie else ''}"


def interval_kind(result: FitResult) -> tuple[str, float | None]:
    """What the result's intervals are ("identified" or "confidence") and, for a confidence interval, its level."""
    kind = result.interval_kind or "identified"
    return kind, result.options.confidence if kind == "confidence" else None


def player_line(result: FitResult) -> list[str]:
    """Under the fitted grid: the model of the player where it is one of people's, and a failed fit check."""
    parts = [f"{result.player_model} player"] if result.player_model not in (None, "boltzmann") else []
    if result.fit_check is not None and result.fit_check.passed is False:
        parts.append("fit check failed: read with care")
    return ["; ".join(parts)] if parts else []


def fit_figure(result: FitResult) -> Figure:
    """The fitted reward beside the true one; the demonstrated policy and carefulness; the intervals."""
    world, mdp = result.world, result.mdp
    board = Board.for_world(world)
    rows, cols = board.shape
    fitted_grid, bounded = shown_reward_grid(result, value_label)
    rewards = [(f"fitted reward ({result.method} point estimate)", fitted_grid)]
    if world.rewards:
        rewards.append(("true reward (world file)", result.true_reward_grid))
    vmax = reward_limit(*(grid for _, grid in rewards))
    demonstrated = result.counts.sum(axis=1) > 0
    policy = policy_panel(mdp, result.counts.argmax(axis=1), title="demonstrated policy", where=demonstrated,
                          counts=result.counts.max(axis=1))
    # Two grids and the colour bar fill the page's width; the policy is as wide as one grid.
    grid_width = (PAGE_WIDTH - COLOUR_BAR_WIDTH) / 2 * 0.92
    grid_height = grid_width * rows / cols + TITLE_HEIGHT
    heights = [grid_height + NOTE_HEIGHT, grid_height + NOTE_HEIGHT]
    timed = result.slip_curve is not None
    if timed:
        heights.append(TIMING_HEIGHT)
    has_intervals = result.intervals is not None and len(result.intervals) > 0
    if has_intervals:
        interval_data, hulls = interval_rows(result)
        kind, confidence = interval_kind(result)
        rmax = float(result.rmax)
        heights.append(FRAME_HEIGHT + LEGEND_HEIGHT + ROW_HEIGHT * len(interval_data))
    width = cell_width(grid_width, cols)
    with figure_style():
        figure = new_figure(PAGE_WIDTH, sum(heights))
        reward_row, middle_row, *rest = figure.subfigures(len(heights), 1, height_ratios=heights, squeeze=False)[:, 0]
        timing_row, interval_row = (rest[0], rest[1:]) if timed else (None, rest)
        axes = reward_row.subplots(1, 2, squeeze=False)[0]
        norm = reward_norm(vmax)
        image = None
        for ax, (title, grid), name in zip(axes, rewards, ("fitted", "true")):
            image = draw_reward(ax, grid, board, norm=norm, title=title, width=width,
                                labels=bounded if name == "fitted" else None)
            ax.set_label(name)
        key = ["≤, ≥: bounded on one side only, no point"] if bounded else []
        axes[0].set_xlabel("\n".join([fitted_cells(result), *key, *player_line(result)]), labelpad=2)
        if len(rewards) == 1:
            axes[1].set_visible(False)  # keeps the fitted grid the same size as with a true one
        assert image is not None, "the fitted reward is always drawn"
        add_colour_bar(reward_row, image, axes, vmax=vmax)
        careful = world.levels > 1 and not timed  # a time world's care is drawn as holds, below
        ax_policy, *ax_careful = middle_row.subplots(1, 2 if careful else 1, squeeze=False)[0]
        draw_policy(ax_policy, policy, board, levels=world.levels,
                    background=result.true_reward_grid if world.rewards else None, vmax=vmax, width=width)
        ax_policy.set_xlabel(policy_note(policy), labelpad=2)
        ax_policy.set_label("policy")
        if careful:
            series = carefulness_by_distance(result.counts, state_distances(mdp), levels=world.levels)
            draw_carefulness(ax_careful[0], [(plural(result.demonstrations['steps'], 'step'), series)],
                             levels=world.levels, title="carefulness by distance to danger")
            ax_careful[0].set_label("carefulness")
        if timing_row is not None:
            ax_curve, ax_holds = timing_row.subplots(1, 2, squeeze=False)[0]
            draw_slip_curve(ax_curve, result)
            ax_curve.set_label("slip curve")
            draw_holds(ax_holds, result)
            ax_holds.set_label("holds")
        if interval_row:
            ax_int = interval_row[0].subplots()
            title = f"{interval_title(result)}{' (hull per symbol)' if hulls else ''}"
            draw_intervals(ax_int, worst_first(interval_data), rmax=rmax, title=title)
            ax_int.set_label("intervals")
            legend = interval_legend(interval_data, kind=kind, confidence=confidence, rmax=rmax)
            interval_row[0].legend(handles=legend, loc="outside lower center", ncol=len(legend),
                                   handlelength=1.2, columnspacing=0.9, handletextpad=0.3)
    return figure
