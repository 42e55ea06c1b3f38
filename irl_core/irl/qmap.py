"""Q as an affine map of the unknowns: the one place every fitter gets its Q from.

The paper (appendix, theorems 1-2) writes Q^pi as an affine function of the reward
through (I - gamma T^pi)^-1, which needs a policy in every state. Demonstrations rarely
cover every state, so the fitters keep the values V as variables instead and use the
Bellman equation itself, which is affine in (R_S, V):

    Q(s, a) = R_S(s) + R_A(a) + gamma * sum_s' P(s' | s, a) V(s')     (s non-terminal)
    Q(s, a) = R_S(s) + gamma * V(exit)                                (s terminal)

With x = [theta; V], where theta (k,) are the unknown state rewards, this is

    Q = M x + q0,   M: (S * A, k + S) sparse, row s * A + a,

and the terminal cells add the equalities V(s) = R_S(s), V(exit) = 0 (E x = e).

Which state rewards are unknown (docs/fitting.md):

===================  ==========================================================
``special``          every non-ground cell is unknown; ground cells are 0
``all``              every cell is unknown
``tie``              one unknown per symbol instead of one per cell
===================  ==========================================================

The known action cost R_A is never fitted, with one exception: where nothing fixes the rewards' units
and every move costs the same (`irl_core.irl.identification`), that cost is in points while the rewards
are relative to a reference, so the fit takes it as one more unknown, ``move`` (a move's cost relative
to the reference, as a reward: negative). A cost common to every action at a non-terminal state is the
same as a reward at every non-terminal state, so ``move`` is a basis column over those states and the
fitting MDP's R_A is 0. The exit state's reward is always 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from irl_core.irl.choices import RewardCells
from irl_core.irl.identification import MOVE
from irl_core.worlds.mdp import MDP
from irl_core.worlds.world import GROUND


@dataclass(frozen=True, eq=False)
class Unknowns:
    """The fitted state rewards: R_S = basis @ theta + fixed.

    Attributes:
        labels: (k,) a name per unknown: a symbol (tied) or ``"C (3, 1)"`` (per cell).
        basis: (S, k) sparse 0/1, basis[s, j] = 1 when unknown j is the reward of state s.
        fixed: (S,) the known part of R_S (0: ground cells are neutral, the exit is 0).
        weight: (k,) cells per unknown, so that ||R_S||_1 = weight @ |theta|.
        symbols: (k,) the layout symbol of each unknown's cells.
        held: (symbol, value) pairs whose cells are known, not fitted (in `fixed`): the rewards a user gave, or
            the reference that gives the rewards their units (`irl_core.irl.identification`).
        move: the index of the ``move`` unknown (a move's cost as a reward at every non-terminal state), or None.
    """

    labels: tuple[str, ...]
    basis: sp.csr_matrix
    fixed: np.ndarray
    weight: np.ndarray
    symbols: tuple[str, ...]
    held: tuple[tuple[str, float], ...] = ()
    move: int | None = None

    @property
    def k(self) -> int:
        return len(self.labels)

    @property
    def cell_basis(self) -> sp.csr_matrix:
        """(S, k) `basis` without the ``move`` column: which unknown is each cell's own reward."""
        if self.move is None:
            return self.basis
        keep = np.ones(self.k)
        keep[self.move] = 0.0
        return (self.basis @ sp.diags(keep)).tocsr()

    @property
    def mask(self) -> np.ndarray:
        """(S,) True at states whose own reward is fitted."""
        return np.asarray(self.cell_basis.sum(axis=1)).ravel() > 0

    def state_rewards(self, theta: np.ndarray) -> np.ndarray:
        """(S,) R_S for unknowns theta (k,), a move's cost included where it is an unknown (what the fitting MDP
        plans with)."""
        return self.basis @ np.asarray(theta, dtype=float) + self.fixed

    def true_theta(self, mdp: MDP) -> np.ndarray:
        """(k,) the world's own rewards as unknowns (the first cell of each unknown; a move's cost as a reward)."""
        first = np.asarray(self.cell_basis.argmax(axis=0)).ravel()
        truth = mdp.R_S[first].astype(float)
        if self.move is not None:
            truth[self.move] = -float(mdp.world.level_costs[0])
        return truth


def build_unknowns(mdp: MDP, *, reward_cells: RewardCells = "special", tie: bool = False,
                   held: tuple[tuple[str, float], ...] = (), move: bool = False) -> Unknowns:
    """The unknown state rewards of `mdp` for `careful fit`'s `--reward-cells` and `--tie`, the cells of each
    `held` symbol known at its value instead, and with `move` one more unknown for a move's cost (the last;
    `mdp` is then the fitting MDP whose R_A is 0)."""
    if reward_cells not in ("special", "all"):
        raise ValueError(f"reward_cells must be 'special' or 'all', not {reward_cells!r}")
    symbols = mdp.symbols
    known = dict(held)
    fixed = np.array([known.get(symbol, 0.0) for symbol in symbols] + [0.0] * (mdp.n_states - len(symbols)))
    fitted = [s for s, symbol in enumerate(symbols) if (reward_cells == "all" or symbol != GROUND)
              and symbol not in known]
    if tie:
        order = list(dict.fromkeys(symbols[s] for s in fitted))
        column = [order.index(symbols[s]) for s in fitted]
        labels = tuple(order)
        unknown_symbols = tuple(order)
    else:
        column = list(range(len(fitted)))
        labels = tuple(f"{symbols[s]} {mdp.cells[s]}" for s in fitted)
        unknown_symbols = tuple(symbols[s] for s in fitted)
    k = len(labels)
    basis = sp.csr_matrix(
        (np.ones(len(fitted)), (np.array(fitted, dtype=np.int64), np.array(column, dtype=np.int64))),
        shape=(mdp.n_states, k),
    )
    weight = np.bincount(np.array(column, dtype=np.int64), minlength=k).astype(float)
    if move:
        moving = np.flatnonzero(mdp.nonterminal)
        column_of_move = sp.csr_matrix((np.ones(moving.size), (moving, np.zeros(moving.size, dtype=np.int64))),
                                       shape=(mdp.n_states, 1))
        basis = sp.hstack([basis, column_of_move], format="csr")
        labels, unknown_symbols, weight = labels + (MOVE,), unknown_symbols + (MOVE,), np.append(weight, 1.0)
    return Unknowns(labels=labels, basis=basis, fixed=fixed, weight=weight, symbols=unknown_symbols,
                    held=tuple((symbol, float(value)) for symbol, value in held), move=k if move else None)


@dataclass(frozen=True, eq=False)
class QMap:
    """Q(s, a) = (M @ x + q0)[s * A + a] for x = [theta (k,); V (S,)].

    Attributes:
        mdp: the world's MDP.
        unknowns: which state rewards theta stands for.
        M: (S * A, k + S) sparse CSR.
        q0: (S * A,) the known part: R_A at non-terminal states plus the fixed R_S.
        E: (n_eq, k + S) sparse CSR, with e (n_eq,): V(s) = R_S(s) at each terminal
            cell and V(exit) = 0, as E @ x = e.
        e: (n_eq,)
    """

    mdp: MDP
    unknowns: Unknowns
    M: sp.csr_matrix
    q0: np.ndarray
    E: sp.csr_matrix
    e: np.ndarray

    @property
    def k(self) -> int:
        """Number of unknown rewards; V(s) is column k + s of x."""
        return self.unknowns.k

    @property
    def n(self) -> int:
        """Number of variables, k + S."""
        return self.unknowns.k + self.mdp.n_states

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(theta (k,), V (S,)) from x (n,)."""
        return x[: self.k], x[self.k : self.n]

    def join(self, theta: np.ndarray, V: np.ndarray) -> np.ndarray:
        """x (n,) from theta (k,) and V (S,)."""
        return np.concatenate([np.asarray(theta, dtype=float), np.asarray(V, dtype=float)])

    def q(self, x: np.ndarray) -> np.ndarray:
        """(S, A) Q for variables x (n,)."""
        return (self.M @ x + self.q0).reshape(self.mdp.n_states, self.mdp.n_actions)

    def value_selector(self, states: np.ndarray) -> sp.csr_matrix:
        """(len(states), n) sparse rows that pick V(s) out of x."""
        states = np.asarray(states, dtype=np.int64)
        return sp.csr_matrix(
            (np.ones(states.size), (np.arange(states.size), self.k + states)), shape=(states.size, self.n)
        )

    def rows(self, states: np.ndarray, actions: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """Q(states[i], actions[i]) as (M rows, q0 entries): one sparse row per pair."""
        index = np.asarray(states, dtype=np.int64) * self.mdp.n_actions + np.asarray(actions, dtype=np.int64)
        return self.M[index], self.q0[index]

    def value_bound(self, rmax: float) -> float:
        """max |V| any policy can reach when |R_S| <= rmax: (rmax + max |R_A|) / (1 - gamma).

        A genuine value function always lies within it, so bounding V by it changes
        no reward's feasibility; it only removes rays along which the value of a
        never-demonstrated state (constrained only from below) could grow for ever.
        """
        largest = rmax + float(np.abs(self.mdp.R_A).max(initial=0.0)) + float(np.abs(self.unknowns.fixed).max())
        return largest / (1.0 - self.mdp.gamma)


def build_qmap(mdp: MDP, unknowns: Unknowns) -> QMap:
    """Assemble M, q0, E and e for `mdp` in a handful of sparse operations (no Python loops)."""
    S, A, k = mdp.n_states, mdp.n_actions, unknowns.k
    # Reward part: row s * A + a gets R_S(s) = basis[s] @ theta (the exit's basis row is empty).
    reward_rows = sp.kron(unknowns.basis, np.ones((A, 1)), format="csr")
    M = sp.hstack([reward_rows, mdp.gamma * mdp.P], format="csr")
    q0 = np.where(np.repeat(mdp.nonterminal, A), np.tile(mdp.R_A, S), 0.0) + np.repeat(unknowns.fixed, A)

    # Terminal cells: V(s) - R_S(s) = fixed(s); the exit: V(exit) = 0.
    terminal = np.flatnonzero(mdp.terminal)
    pick_v = sp.csr_matrix(
        (np.ones(terminal.size + 1), (np.arange(terminal.size + 1), k + np.append(terminal, mdp.exit_state))),
        shape=(terminal.size + 1, k + S),
    )
    pick_r = sp.vstack([unknowns.basis[terminal], sp.csr_matrix((1, k))])
    E = (pick_v - sp.hstack([pick_r, sp.csr_matrix((terminal.size + 1, S))])).tocsr()
    e = np.append(unknowns.fixed[terminal], 0.0)
    return QMap(mdp=mdp, unknowns=unknowns, M=M, q0=q0, E=E, e=e)
