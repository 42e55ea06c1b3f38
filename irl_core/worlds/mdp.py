"""The tabular MDP of a world (docs/worlds.md), with transitions stored sparsely.

=============  ==============================================================
states         every non-wall cell in row-major order, then one absorbing
               exit state (index ``S - 1``) that terminal cells lead to
actions        a = d * L + (c - 1): direction d in (up, right, down, left),
               carefulness c in 1..L
transitions    ``P``: (S * A, S) sparse, row ``s * A + a`` is P(. | s, a).
               Halving slip: the chosen direction with 1 - 2^-c, each other
               direction with 2^-c / 3 (a time world: p(d) of the bin's
               mid-point for 2^-c); a fixed slip: its own split
               (`World.direction_split`). ``bump = "stay"``: off the grid
               or into a wall: stay. ``bump = "drop"``: such a move is not
               made, so a step is one of the moves that lead somewhere, in
               proportion to their chances (the player presses again); an
               action with no such move keeps the stay rule (the game ignores
               its key, so no recording holds it). A terminal cell moves to
               the exit with any action; the exit stays where it is.
rewards        R(s, a) = R_S(s) + R_A(a) at a non-terminal cell, with
               R_A(a) = -cost_per_level * c (a time world: the cost of the
               bin's mid-point); R_S(s) at a terminal cell (no
               action cost); 0 at the exit.
=============  ==============================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from irl_core.worlds.world import DIRECTIONS, Cell, World

# (row, col) offsets in the order of DIRECTIONS.
OFFSETS = np.array([(-1, 0), (0, 1), (1, 0), (0, -1)])



def action_index(direction: str | int, carefulness: int, levels: int) -> int:
    """a = d * L + (c - 1)."""
    d = DIRECTIONS.index(direction) if isinstance(direction, str) else int(direction)
    return d * levels + (carefulness - 1)


def action_parts(action: int, levels: int) -> tuple[str, int]:
    """(direction name, carefulness) of action index a."""
    return DIRECTIONS[action // levels], action % levels + 1


def attempt_split(world: World) -> np.ndarray:
    """(A, 4) the chance that action a, as pressed, goes in each direction (action order), before a wall or
    the grid's edge has its say: `World.direction_split` by action."""
    split = world.direction_split()  # (L, 4 chosen, 4 realised)
    return split.transpose(1, 0, 2).reshape(4 * world.levels, 4)


def made_move_chances(split: np.ndarray, leads: np.ndarray, *, drop: bool) -> np.ndarray:
    """(..., 4) the chance of each realised direction of a step that is made, from the attempts' chances
    `split` (..., 4) and `leads` (..., 4), True where a direction leads to another cell. With `drop` the
    moves that lead nowhere are not made: the rest share their chances in proportion (an attempt with no
    such move keeps its own chances, each a step that stays); without it they are steps that stay."""
    if not drop:
        return split
    kept = split * leads
    total = kept.sum(axis=-1, keepdims=True)
    return np.where(total > 0, kept / np.where(total > 0, total, 1.0), split)


def from_chosen(chances: np.ndarray, chosen: np.ndarray | int) -> np.ndarray:
    """(..., 4) `chances` (..., 4) of each direction in action order, turned to start at `chosen` (...): column
    k is the direction (chosen + k) % 4. Every sampler draws k in this order, so that a seed plays the game it
    played before fixed splits existed (a recording made again from its seed is the same)."""
    turn = (np.asarray(chosen)[..., None] + np.arange(4)) % 4
    return np.take_along_axis(chances, turn, axis=-1)


def sample_direction(chances: np.ndarray, chosen: int, rng: np.random.Generator) -> int:
    """One realised direction (index, action order) drawn from `chances` (4,) for a move chosen as `chosen`."""
    return (chosen + int(rng.choice(4, p=from_chosen(chances, chosen)))) % 4


@dataclass(frozen=True, eq=False)
class MDP:
    """A world as arrays. Build it with `build_mdp`.

    Attributes:
        world: the world it was built from.
        cells: (S - 1) cells, state s is cells[s]; the exit state has no cell.
        neighbour: (S, 4) state reached by moving in each direction (the exit maps to itself).
        leads: (S, 4) True where that direction leads to another cell (not a wall or off the grid).
        split: (A, 4) the chance that action a, as pressed, goes in each direction (`attempt_split`).
        terminal: (S,) True at terminal cells.
        P: (S * A, S) sparse CSR transition probabilities, row s * A + a.
        R_S: (S,) true state rewards from the world (0 at the exit).
        R_A: (A,) known action costs, -cost_per_level * c (`World.level_costs`).
    """

    world: World
    cells: tuple[Cell, ...]
    neighbour: np.ndarray
    leads: np.ndarray
    split: np.ndarray
    terminal: np.ndarray
    P: sp.csr_matrix
    R_S: np.ndarray
    R_A: np.ndarray

    @property
    def n_states(self) -> int:
        return len(self.cells) + 1

    @property
    def n_actions(self) -> int:
        return 4 * self.world.levels

    @property
    def levels(self) -> int:
        return self.world.levels

    @property
    def gamma(self) -> float:
        return self.world.gamma

    @property
    def exit_state(self) -> int:
        return len(self.cells)

    @cached_property
    def state_of(self) -> dict[Cell, int]:
        """Cell (row, col) to state index."""
        return {cell: s for s, cell in enumerate(self.cells)}

    @cached_property
    def carefulness(self) -> np.ndarray:
        """(A,) carefulness c of each action."""
        return np.arange(self.n_actions) % self.levels + 1

    @cached_property
    def direction(self) -> np.ndarray:
        """(A,) direction index d of each action."""
        return np.arange(self.n_actions) // self.levels

    @cached_property
    def nonterminal(self) -> np.ndarray:
        """(S,) True at states where the agent acts: neither terminal nor the exit."""
        mask = ~self.terminal
        mask[self.exit_state] = False
        return mask

    @cached_property
    def symbols(self) -> tuple[str, ...]:
        """(S - 1) layout symbol of each cell state."""
        return tuple(self.world.symbol(cell) for cell in self.cells)

    def grid_of(self, per_state: np.ndarray, *, fill: float = np.nan) -> np.ndarray:
        """(rows, cols) from a per-state array (S,) (the exit dropped), `fill` at walls."""
        out = np.full((self.world.rows, self.world.cols), fill, dtype=float)
        rc = np.array(self.cells).reshape(-1, 2)
        out[rc[:, 0], rc[:, 1]] = np.asarray(per_state, dtype=float)[: len(self.cells)]
        return out

    def reward_matrix(self, R_S: np.ndarray | None = None) -> np.ndarray:
        """(S, A) R(s, a) for state rewards R_S (S,), the world's own by default."""
        R_S = self.R_S if R_S is None else np.asarray(R_S, dtype=float)
        R = np.where(self.nonterminal[:, None], R_S[:, None] + self.R_A[None, :], R_S[:, None])
        R[self.exit_state] = 0.0
        return np.broadcast_to(R, (self.n_states, self.n_actions)).copy()

    def expected_next(self, V: np.ndarray) -> np.ndarray:
        """(S, A) sum_s' P(s' | s, a) V(s') for values V (S,)."""
        return (self.P @ V).reshape(self.n_states, self.n_actions)

    def step_chances(self, state: np.ndarray | int, action: np.ndarray | int) -> np.ndarray:
        """(..., 4) the chance of each realised direction (action order) of a step made with `action` (...)
        from `state` (...): what P holds, by direction (`made_move_chances`)."""
        return made_move_chances(self.split[action], self.leads[state], drop=self.world.bump == "drop")

    def move(self, state: int, action: int, rng: np.random.Generator) -> tuple[int, int]:
        """Sample one step as P has it: (next state, realised direction index)."""
        realised = sample_direction(self.step_chances(state, action), action // self.levels, rng)
        if not self.nonterminal[state]:
            return self.exit_state, realised
        return int(self.neighbour[state, realised]), realised


def build_mdp(world: World) -> MDP:
    """The MDP of `world`; transitions are assembled as one sparse COO batch."""
    cells = tuple(world.cells)
    n_cells = len(cells)
    S, L = n_cells + 1, world.levels
    A = 4 * L
    exit_state = n_cells

    index = np.full((world.rows, world.cols), -1, dtype=np.int64)
    rc = np.array(cells, dtype=np.int64).reshape(-1, 2)
    index[rc[:, 0], rc[:, 1]] = np.arange(n_cells)

    # neighbour[s, d]: the state reached moving in direction d (itself at an edge or wall).
    target = rc[:, None, :] + OFFSETS[None, :, :]
    inside = (
        (target[..., 0] >= 0) & (target[..., 0] < world.rows) & (target[..., 1] >= 0) & (target[..., 1] < world.cols)
    )
    moved = np.where(inside, index[target[..., 0].clip(0, world.rows - 1), target[..., 1].clip(0, world.cols - 1)], -1)
    neighbour = np.where(moved >= 0, moved, np.arange(n_cells)[:, None])
    neighbour = np.vstack([neighbour, np.full((1, 4), exit_state)])
    leads = np.vstack([moved >= 0, np.zeros((1, 4), dtype=bool)])

    terminal = np.zeros(S, dtype=bool)
    terminal[:n_cells] = [world.symbol(cell) in world.terminal for cell in cells]
    acting = np.flatnonzero(~terminal[:n_cells])

    # For each acting state, action a and realised direction k: the chance of the step (s, a) going k.
    c = np.arange(A) % L + 1
    split = attempt_split(world)  # (A, 4)
    rows = (acting[:, None, None] * A + np.arange(A)[None, :, None]).repeat(4, axis=2)
    cols = np.broadcast_to(neighbour[acting][:, None, :], rows.shape)  # (n_acting, A, 4)
    data = made_move_chances(split[None, :, :], leads[acting][:, None, :], drop=world.bump == "drop")
    data = np.broadcast_to(data, cols.shape)

    # Terminal cells and the exit move to the exit with probability 1 under every action.
    absorbing = np.append(np.flatnonzero(terminal[:n_cells]), exit_state)
    abs_rows = (absorbing[:, None] * A + np.arange(A)[None, :]).ravel()

    P = sp.csr_matrix(
        (
            np.concatenate([data.ravel(), np.ones(abs_rows.size)]),
            (np.concatenate([rows.ravel(), abs_rows]), np.concatenate([cols.ravel(), np.full(abs_rows.size, exit_state)])),
        ),
        shape=(S * A, S),
    )
    P.sum_duplicates()
    P.eliminate_zeros()

    R_S = np.array([world.reward_of(world.symbol(cell)) for cell in cells] + [0.0])
    R_A = -np.asarray(world.level_costs, dtype=float)[c - 1]
    return MDP(world=world, cells=cells, neighbour=neighbour, leads=leads, split=split, terminal=terminal, P=P,
               R_S=R_S, R_A=R_A)
