"""Widgets shared by the play, replay and fit screens."""

from careful_tui.widgets.board import Arrow, Board, BoardGrid
from careful_tui.widgets.gauge import Gauge, level_colour
from careful_tui.widgets.keybar import KeyBar

__all__ = ["Arrow", "Board", "BoardGrid", "Gauge", "KeyBar", "level_colour"]
