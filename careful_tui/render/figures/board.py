"""A world's cells as arrays, the common ground of every grid figure (no matplotlib here)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from irl_core.worlds.world import WALL, World

GROUND = "."


@dataclass(frozen=True, eq=False)
class Board:
    """What each cell of a grid is.

    Attributes:
        symbols: (rows, cols) str, the layout symbol of each cell.
        wall: (rows, cols) bool, True where a wall is (not a state).
        terminal: (rows, cols) bool, True where entering ends the episode.
    """

    symbols: np.ndarray
    wall: np.ndarray
    terminal: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.symbols.shape

    @classmethod
    def for_world(cls, world: World) -> Board:
        """`world`'s cells: its symbols, its walls and its terminal cells."""
        symbols = np.array([list(row) for row in world.grid], dtype="<U1")
        return cls(symbols=symbols, wall=symbols == WALL, terminal=np.isin(symbols, list(world.terminal)))

    def rewards(self, world: World) -> np.ndarray:
        """(rows, cols) the world's own R_S per cell, NaN at walls."""
        values = np.vectorize(world.reward_of, otypes=[float])(self.symbols)
        return np.where(self.wall, np.nan, values)
