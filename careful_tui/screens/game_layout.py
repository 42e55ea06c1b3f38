"""The layout the play and replay screens share: the gauge and the hold's numbers on the left,
the board and a status under it on the right, a title above and keys below.

`compose_game` yields it (the replay adds its session panel on the right) and
`minimum_size` computes the smallest terminal it fits in, from the paddings each screen's
stylesheet gives it.
"""

from __future__ import annotations

import math

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Horizontal, Vertical
from textual.widget import Widget
from textual.widgets import Static

from careful_tui.render.session import legend
from careful_tui.widgets import Board, Gauge, KeyBar
from careful_tui.widgets.board import SMALLEST_CELL
from careful_tui.widgets.too_small import TooSmall
from irl_core.play.game import level_costs, level_slip_chances
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable
from irl_core.worlds.world import World

STATUS_LINES = 3
# The status under the board needs this many columns whatever the board's width (a 6-column world's board
# of 7-wide cells, which its sentences were written for).
STATUS_WIDTH = 44


def carefulness_gauge(world: World, *, slips: bool = False) -> Gauge:
    """The gauge of the play and replay screens: one step per level, each with its cost (and with
    `slips` the chance that a move of that level slips, from the world's dynamics)."""
    gauge = Gauge(level_costs(world), slips=level_slip_chances(world) if slips else None, id="gauge")
    gauge.border_title = "carefulness"
    # A time world shows no levels: the player sees the board, the score and at most the held time.
    gauge.display = world.care != "time"
    if slips:
        gauge.border_subtitle = "points slip"
    return gauge


def world_board(world: World, *, show_rewards: bool = True) -> Board:
    """The board of the play and replay screens, titled with the world and its legend (with each symbol's
    reward when `show_rewards`)."""
    board = Board(world, id="board")
    care = ("care is how long you hold" if world.care == "time" else
            f"{plural(world.levels, 'level')} · slip {world.slip_label}")
    board.border_title = Text(f"{printable(world.name, limit=40)} · {care}")
    board.border_subtitle = legend(world, show_rewards=show_rewards)
    return board


def compose_game(world: World, *, panel: Widget | None = None, slips: bool = False, status: Widget | None = None,
                 hold_info: Widget | None = None, show_rewards: bool = True) -> ComposeResult:
    """Title, gauge (with `slips`, each level's slip chance) and hold info, board and status (and
    `panel` on the right), the key bar; `status` and `hold_info` replace the plain `Static`s."""
    yield Static(id="title")
    with Horizontal(id="main"):
        with Vertical(id="side", classes="time" if world.care == "time" else ""):
            yield carefulness_gauge(world, slips=slips)
            yield Static(id="hold-info") if hold_info is None else hold_info
        with Vertical(id="right"):
            yield world_board(world, show_rewards=show_rewards)
            yield Static(id="status") if status is None else status
        if panel is not None:
            yield panel
    yield TooSmall(id="too-small")
    yield KeyBar(id="keys")


def minimum_size(world: World, *, side_padding: int, panel_width: int = 0, panel_share: float = 0.0,
                 side_lines: int = 0, slips: bool = False) -> tuple[int, int]:
    """The smallest terminal (columns, rows) the layout fits in, for `world`.

    `side_padding`: columns the gauge's border, padding and margin add to it; `panel_width`: the
    least columns of a panel on the right, and `panel_share` the share of the columns beside the
    gauge it takes where that is more; `side_lines`: lines under the gauge that must show; `slips`:
    the gauge shows slip chances.
    """
    gauge_width = carefulness_gauge(world, slips=slips).get_content_width(None, None)
    cell_width, cell_height = SMALLEST_CELL
    # A title bar and a key bar; the board's border and the status lines under it.
    levels = 0 if world.care == "time" else world.levels
    board = max(world.cols * cell_width + 2, STATUS_WIDTH)
    width = (gauge_width + side_padding) + max(board + panel_width, math.ceil(board / (1 - panel_share)))
    height = 2 + max(levels + 2 + side_lines, world.rows * cell_height + 2 + STATUS_LINES)
    return width, height
