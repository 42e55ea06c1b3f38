"""Policies on a grid: an arrow per cell, its width and a number showing carefulness.

A demonstrated policy (the most frequent action per cell) also shows how often that action
was taken: the arrow's opacity grows with its count, so well-trodden cells stand out and a
cell seen once is faint. Cells are tinted by the true reward on the reward figures' colour
scale, so the cliff and the goal look the same in every figure.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrowPatch

from careful_tui.render.figures.board import GROUND, Board
from careful_tui.render.figures.heatmap import (
    FULL_CELL,
    REWARD_CMAP,
    TITLE_HEIGHT,
    cell_text_size,
    cell_width,
    draw_board,
    reward_limit,
    reward_norm,
)
from careful_tui.render.figures.style import INK, PANEL_WIDTH, figure_style, new_figure, plain
from irl_core.worlds.mdp import MDP

# (dx, dy) on the page for up, right, down, left; rows grow downwards.
STEP = np.array([(0, -1), (1, 0), (0, 1), (-1, 0)], dtype=float)
NOTE_HEIGHT = 0.18  # inches for the line under a demonstrated policy


@dataclass(frozen=True, eq=False)
class PolicyPanel:
    """One policy to draw.

    Attributes:
        title: the panel's title.
        direction: (rows, cols) int, 0..3 for up, right, down, left; -1 where no arrow is drawn.
        carefulness: (rows, cols) int, the level 1..L of each arrow.
        count: (rows, cols) how often each drawn action was demonstrated, or None for a
            policy that is not data (an optimal policy): then every arrow is opaque.
    """

    title: str
    direction: np.ndarray
    carefulness: np.ndarray
    count: np.ndarray | None = None


def policy_panel(mdp: MDP, actions: np.ndarray, *, title: str, where: np.ndarray | None = None,
                 counts: np.ndarray | None = None) -> PolicyPanel:
    """A panel from an action per state.

    Args:
        actions: (S,) action index per state (a = d * L + c - 1).
        where: (S,) bool, the states to draw (default: every non-terminal state).
        counts: (S,) how often each state's action was demonstrated, for a demonstrated policy.
    """
    where = mdp.nonterminal if where is None else where
    rows, cols = mdp.world.rows, mdp.world.cols
    direction = np.full((rows, cols), -1)
    carefulness = np.ones((rows, cols), dtype=int)
    count = None if counts is None else np.zeros((rows, cols))
    for s, (r, c) in enumerate(mdp.cells):
        if where[s]:
            direction[r, c] = int(actions[s]) // mdp.levels
            carefulness[r, c] = int(actions[s]) % mdp.levels + 1
            if count is not None and counts is not None:
                count[r, c] = counts[s]
    return PolicyPanel(title, direction, carefulness, count)


def faded(colour: str, strength: float) -> tuple[float, float, float]:
    """`colour` mixed with white: strength 1 is the colour, 0 is white (opaque, so heads and shafts match)."""
    rgb = np.array(to_rgb(colour))
    return tuple(1.0 - strength * (1.0 - rgb))


def arrow_width(carefulness: int, levels: int, *, scale: float = 1.0) -> float:
    """Line width in points: 0.6 at level 1 up to 2.6 at level L, times `scale` for small cells."""
    return (0.6 + 2.0 * (carefulness - 1) / max(levels - 1, 1)) * scale


def draw_policy(ax: Axes, panel: PolicyPanel, board: Board, *, levels: int,
                background: np.ndarray | None = None, vmax: float | None = None,
                width: float = FULL_CELL) -> None:
    """Arrows on `ax`, over the board tinted by `background` (rows, cols) rewards when given.

    `width`: points per cell: arrows shrink in cells narrower than `FULL_CELL`, and levels (and
    terminal cells' symbols) are written only where they can be read.
    """
    text_size = cell_text_size(width)
    scale = min(1.0, width / FULL_CELL)
    if background is not None:
        shown = np.ma.masked_invalid(np.where(board.wall, np.nan, background))
        norm = reward_norm(vmax or reward_limit(background))
        ax.imshow(shown, cmap=REWARD_CMAP, norm=norm, alpha=0.45, interpolation="nearest", zorder=1)
    draw_board(ax, board, width=width)
    ax.set_title(panel.title, pad=3)
    most = float(panel.count.max()) if panel.count is not None and panel.count.max() > 0 else 1.0
    for (r, c), d in np.ndenumerate(panel.direction):
        if d < 0:
            if text_size is not None and board.symbols[r, c] != GROUND and not board.wall[r, c]:
                ax.text(c, r, plain(str(board.symbols[r, c])), ha="center", va="center", fontsize=text_size, color=INK,
                        zorder=5)
            continue
        level = int(panel.carefulness[r, c])
        strength = 1.0 if panel.count is None else 0.2 + 0.8 * float(panel.count[r, c]) / most
        ink = faded(INK, strength)
        dx, dy = STEP[d] * 0.32
        ax.add_patch(FancyArrowPatch((c - dx, r - dy), (c + dx, r + dy), arrowstyle="-|>",
                                     mutation_scale=(4 + 2.2 * arrow_width(level, levels)) * scale,
                                     linewidth=arrow_width(level, levels, scale=scale), color=ink,
                                     shrinkA=0, shrinkB=0, zorder=5))
        if text_size is not None and levels > 1:
            # The level beside the shaft: left of a vertical arrow, above a horizontal one.
            nx, ny = (0.3, 0.0) if d in (0, 2) else (0.0, -0.28)
            ax.text(c - nx, r + ny, str(level), ha="center", va="center", fontsize=text_size - 0.5,
                    color=faded(INK, max(strength, 0.6)), zorder=5)  # faint arrows, readable numbers


def policy_figure(panels: Sequence[PolicyPanel], board: Board, *, levels: int,
                  background: np.ndarray | None = None, vmax: float | None = None,
                  panel_width: float = PANEL_WIDTH) -> Figure:
    """Policies side by side (e.g. demonstrated beside optimal), one panel each.

    Args:
        levels: L, the number of carefulness levels (arrow widths run from level 1 to L).
        background: (rows, cols) rewards that tint the cells (the true reward), or None.
    """
    rows, cols = board.shape
    demonstrated = [p for p in panels if p.count is not None]
    with figure_style():
        height = panel_width * rows / cols + TITLE_HEIGHT + (NOTE_HEIGHT if demonstrated else 0)
        figure = new_figure(panel_width * len(panels), height)
        axes = figure.subplots(1, len(panels), squeeze=False)[0]
        for ax, panel in zip(axes, panels):
            draw_policy(ax, panel, board, levels=levels, background=background, vmax=vmax,
                        width=cell_width(panel_width, cols))
            if panel.count is not None:
                ax.set_xlabel(policy_note(panel), labelpad=2)
    return figure


def policy_note(panel: PolicyPanel) -> str:
    """What the marks of a demonstrated policy mean, with its largest count."""
    most = int(panel.count.max()) if panel.count is not None else 0
    return f"darker: taken more often (max {most}×)"
