"""A world's transitions in direction form: products with P at the cost of its directions, not its actions.

At an acting state every action reaches the same four neighbours, each direction k with its own chance, so

    P(s' | s, a) = sum_k toward[a, k] [s' = neighbour(s, k)],

toward (A, 4) the same at every state (`MDP.split`), except, in a world whose moves into a wall are dropped,
at the cells beside a wall or the grid's edge, where a step's chances depend on which directions lead
somewhere (`MDP.step_chances`; `blocked_toward` holds theirs); a terminal cell and the exit lead to the exit
under every action.
A pull-back X @ P then adds up 4 weights per state instead of 4 per action (56 actions in a 14-level
world), and so does a policy's system I - gamma P^pi. Large worlds' maximum-entropy and people fits use
both (`irl_core.irl.maxent`); `MDP.P` stays the definition, and `tests/core/test_moves.py` checks every
product here against it. (P @ V, each action's expected next value, gains nothing this way: `P`'s sparse
product is as fast.)
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from irl_core.worlds.mdp import MDP


@dataclass(frozen=True, eq=False)
class Moves:
    """`mdp`'s transitions in direction form.

    Attributes:
        neighbour: (S, 4) the state each direction leads to (`MDP.neighbour`).
        acting: (S,) True where the agent acts (`MDP.nonterminal`).
        toward: (A, 4) each action's chance of each direction where nothing is in the way.
        blocked: (n,) the states whose own chances differ (a dropping world's cells beside a wall or the edge);
            blocked_toward: (n, A, 4) their chances.
        place: where each acting state's four neighbour weights, then each other state's exit weight, land in
            the CSC data of a policy system; diagonal (S,): where its diagonal lands; indices, indptr: the CSC
            structure.
        below, above: how many diagonals below and above the main one the system's nonzeros reach.
        in_band: (2, nnz) where each CSC entry lands in LAPACK's band storage of the system, then of its transpose
            (`PolicySystem.band`).
    """

    neighbour: np.ndarray
    acting: np.ndarray
    exit_state: int
    levels: int
    toward: np.ndarray
    blocked: np.ndarray
    blocked_toward: np.ndarray
    place: np.ndarray
    diagonal: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray
    below: int
    above: int
    in_band: np.ndarray

    @property
    def n_states(self) -> int:
        return self.neighbour.shape[0]

    @cached_property
    def _one_by_action(self) -> np.ndarray:
        return np.ones(4 * self.levels)

    def weights(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For X (S, A): (S, 4) sum_a X(s, a) P(neighbour(s, k) | s, a) counted once per direction k at acting
        states (0 elsewhere), and (S,) sum_a X(s, a), what each state not acting sends to the exit (0 where
        it acts)."""
        S, L = self.n_states, self.levels
        X = np.asarray(X, dtype=float).reshape(S, 4 * L)
        # Products, not sums over the middle axis: numpy's sum there was half the time of this function.
        toward = X @ self.toward
        if self.blocked.size:
            toward[self.blocked] = np.einsum("sa,sak->sk", X[self.blocked], self.blocked_toward)
        toward[~self.acting] = 0.0
        to_exit = np.where(self.acting, 0.0, X @ self._one_by_action)
        return toward, to_exit

    def pulled_back(self, X: np.ndarray) -> np.ndarray:
        """(S,) sum_{s, a} X(s, a) P(s' | s, a) for X (S, A): X.ravel() @ P."""
        toward, to_exit = self.weights(X)
        out = np.bincount(self.neighbour.ravel(), weights=toward.ravel(), minlength=self.n_states)
        out[self.exit_state] += to_exit.sum()
        return out

    def policy_system(self, pi: np.ndarray, *, gamma: float) -> PolicySystem:
        """(S, S) I - gamma P^pi for the policy pi (S, A)."""
        toward, to_exit = self.weights(pi)
        weights = np.concatenate([toward[self.acting].ravel(), to_exit[~self.acting]])
        data = np.bincount(self.place, weights=-gamma * weights,
                           minlength=self.indices.size)
        data[self.diagonal] += 1.0
        return PolicySystem(self, data)


@dataclass(frozen=True, eq=False)
class PolicySystem:
    """A policy's system I - gamma P^pi (or its transpose) as the values of its entries in the world's fixed
    pattern (`Moves.indices`, `Moves.indptr`), so that a solver can lay it out without looking for its shape.

    Attributes:
        moves: the world's moves, whose pattern `data` fills.
        data: (nnz,) the CSC entries of I - gamma P^pi.
        transposed: whether this stands for the transpose.
    """

    moves: Moves
    data: np.ndarray
    transposed: bool = False

    @property
    def T(self) -> PolicySystem:
        """The transpose, under numpy's and scipy's name for it: a fit's policy system is a dense array in small
        worlds and this in large ones, and its solver takes `.T` of either alike."""
        return replace(self, transposed=not self.transposed)

    @property
    def shape(self) -> tuple[int, int]:
        S = self.moves.n_states
        return S, S

    def tocsc(self) -> sp.csc_matrix:
        moves = self.moves
        system = sp.csc_matrix((self.data, moves.indices, moves.indptr), shape=self.shape)
        return system.T.tocsc() if self.transposed else system

    def toarray(self) -> np.ndarray:
        return self.tocsc().toarray()

    def band(self) -> tuple[int, int, np.ndarray]:
        """(below, above, ab): the system in LAPACK's general band storage for `dgbsv`, row below + above + i - j
        of column j holding entry (i, j), with `below` rows on top left free for the factorisation's fill."""
        moves = self.moves
        below, above = (moves.above, moves.below) if self.transposed else (moves.below, moves.above)
        S = moves.n_states
        ab = np.zeros((2 * below + above + 1) * S)
        ab[moves.in_band[1] if self.transposed else moves.in_band[0]] = self.data
        return below, above, ab.reshape(2 * below + above + 1, S)


_MOVES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def moves_of(mdp: MDP) -> Moves:
    """`mdp`'s `Moves`, built once per MDP."""
    moves = _MOVES.get(mdp)
    if moves is None:
        moves = _MOVES[mdp] = _build(mdp)
    return moves


def _build(mdp: MDP) -> Moves:
    S, exit_state = mdp.n_states, mdp.exit_state
    # Only a dropping world's acting cells beside a wall or the edge have chances of their own.
    blocked = np.flatnonzero(np.asarray(mdp.nonterminal) & ~np.asarray(mdp.leads).all(axis=1)) \
        if mdp.world.bump == "drop" else np.zeros(0, dtype=int)
    blocked_toward = mdp.step_chances(blocked[:, None], np.arange(mdp.n_actions)[None, :])  # (n, A, 4)
    neighbour = np.asarray(mdp.neighbour)
    acting = np.asarray(mdp.nonterminal)
    acting_states, others = np.flatnonzero(acting), np.flatnonzero(~acting)
    rows = np.concatenate([np.repeat(acting_states, 4), others, np.arange(S)])
    cols = np.concatenate([neighbour[acting].ravel(), np.full(others.size, exit_state), np.arange(S)])
    # Column-major order of the (row, col) pairs, each once: the CSC matrix's data order.
    keys, where = np.unique(cols.astype(np.int64) * S + rows, return_inverse=True)
    row, col = keys % S, keys // S
    below, above = int((row - col).max()), int((col - row).max())
    # Entry (i, j) in the band of the system (below, above) and of its transpose (above, below), flattened.
    in_band = np.stack([(below + above + row - col) * S + col, (above + below + col - row) * S + row])
    return Moves(neighbour=neighbour, acting=acting, exit_state=exit_state, levels=mdp.levels, toward=mdp.split,
                 blocked=blocked, blocked_toward=blocked_toward, place=where[: rows.size - S], diagonal=where[rows.size - S:],
                 indices=row.astype(np.int32), indptr=np.searchsorted(col, np.arange(S + 1)).astype(np.int32),
                 below=below, above=above, in_band=in_band)
