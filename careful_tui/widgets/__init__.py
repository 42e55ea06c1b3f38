"""Widgets the screens share: the board, the carefulness gauge, the key bar and the too-small notice;
play's status and hold numbers (`play_status`).

May import: `irl_core`, `careful_tui.render` and Textual's public API. Never a screen, the app
or a command.
"""

from careful_tui.widgets.board import Arrow, Board, BoardGrid
from careful_tui.widgets.gauge import Gauge
from careful_tui.widgets.keybar import KeyBar

__all__ = ["Arrow", "Board", "BoardGrid", "Gauge", "KeyBar"]
