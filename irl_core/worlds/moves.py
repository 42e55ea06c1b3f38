"""A world's transitions in direction form: products with P at the cost of its directions, not its actions.

At an acting state every level of a direction reaches the same four neighbours, and the halving slip
gives the chosen direction 1 - 3e and each other direction e (e = the level's slip chance / 3), so

    P(s' | s, (d, c)) = chosen[c] [s' = neighbour(s, d)] + even[c] sum_k [s' = neighbour(s, k)],

chosen[c] = 1 - 4e and even[c] = e; a terminal cell and the exit lead to the exit under every action.
A pull-back X @ P then adds up 4 weights per state instead of 4 per action (56 actions in a 14-level
world), and so does a policy's system I - gamma P^pi. Large worlds' maximum-entropy and people fits use
both (`irl_core.irl.maxent`); `MDP.P` stays the definition, and `tests/core/test_moves.py` checks every
product here against it. (P @ V, each action's expected next value, gains nothing this way: `P`'s sparse
product is as fast.)
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.worlds.mdp import MDP, direction_probabilities


@dataclass(frozen=True, eq=False)
class Moves:
    """`mdp`'s transitions in direction form.

    Attributes:
        neighbour: (S, 4) the state each direction leads to (`MDP.neighbour`).
        acting: (S,) True where the agent acts (`MDP.nonterminal`).
        chosen: (L,) each level's chance of the chosen direction beyond the even share.
        even: (L,) each level's chance of every direction, the chosen one included.
        place: where each acting state's four neighbour weights, then each other state's exit weight, land in
            the CSC data of a policy system; diagonal (S,): where its diagonal lands; indices, indptr: the CSC
            structure.
    """

    neighbour: np.ndarray
    acting: np.ndarray
    exit_state: int
    levels: int
    chosen: np.ndarray
    even: np.ndarray
    place: np.ndarray
    diagonal: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray

    @property
    def n_states(self) -> int:
        return self.neighbour.shape[0]

    def weights(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For X (S, A): (S, 4) sum_a X(s, a) P(neighbour(s, k) | s, a) counted once per direction k at acting
        states (0 elsewhere), and (S,) sum_a X(s, a), what each state not acting sends to the exit (0 where
        it acts)."""
        S, L = self.n_states, self.levels
        X3 = np.asarray(X, dtype=float).reshape(S, 4, L)
        toward = X3 @ self.chosen + (X3.sum(axis=1) @ self.even)[:, None]
        toward[~self.acting] = 0.0
        to_exit = np.where(self.acting, 0.0, X3.sum(axis=(1, 2)))
        return toward, to_exit

    def pulled_back(self, X: np.ndarray) -> np.ndarray:
        """(S,) sum_{s, a} X(s, a) P(s' | s, a) for X (S, A): X.ravel() @ P."""
        toward, to_exit = self.weights(X)
        out = np.bincount(self.neighbour.ravel(), weights=toward.ravel(), minlength=self.n_states)
        out[self.exit_state] += to_exit.sum()
        return out

    def policy_system(self, pi: np.ndarray, *, gamma: float) -> sp.csc_matrix:
        """(S, S) I - gamma P^pi for the policy pi (S, A), sparse."""
        toward, to_exit = self.weights(pi)
        weights = np.concatenate([toward[self.acting].ravel(), to_exit[~self.acting]])
        data = np.bincount(self.place, weights=-gamma * weights,
                           minlength=self.indices.size)
        data[self.diagonal] += 1.0
        S = self.n_states
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(S, S))


_MOVES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def moves_of(mdp: MDP) -> Moves:
    """`mdp`'s `Moves`, built once per MDP."""
    moves = _MOVES.get(mdp)
    if moves is None:
        moves = _MOVES[mdp] = _build(mdp)
    return moves


def _build(mdp: MDP) -> Moves:
    S, exit_state = mdp.n_states, mdp.exit_state
    probs = direction_probabilities(np.arange(1, mdp.levels + 1), world=mdp.world)  # (L, 4)
    even = probs[:, 1]
    chosen = probs[:, 0] - even
    neighbour = np.asarray(mdp.neighbour)
    acting = np.asarray(mdp.nonterminal)
    acting_states, others = np.flatnonzero(acting), np.flatnonzero(~acting)
    rows = np.concatenate([np.repeat(acting_states, 4), others, np.arange(S)])
    cols = np.concatenate([neighbour[acting].ravel(), np.full(others.size, exit_state), np.arange(S)])
    # Column-major order of the (row, col) pairs, each once: the CSC matrix's data order.
    keys, where = np.unique(cols.astype(np.int64) * S + rows, return_inverse=True)
    return Moves(neighbour=neighbour, acting=acting, exit_state=exit_state, levels=mdp.levels, chosen=chosen,
                 even=even, place=where[: rows.size - S], diagonal=where[rows.size - S:],
                 indices=(keys % S).astype(np.int32), indptr=np.searchsorted(keys // S, np.arange(S + 1)).astype(np.int32))
