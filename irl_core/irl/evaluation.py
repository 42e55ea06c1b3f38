"""What an agent trained on a fitted reward would do (docs/answers.md, `evaluation`).

Plan optimally for the fitted R_S (with the known action cost), then evaluate that policy
exactly in the world with its true rewards, from the world's start distribution: no sampling.

Under a fixed policy the world is an absorbing Markov chain. With T the non-terminal states,
Q = P^pi restricted to T x T and B = P^pi restricted to T x (terminal cells), the probability
of ending in each terminal cell from each start is X = (I - Q)^-1 B; from the start
distribution p it is p_T X = y B with (I - Q)^T y = p_T, one sparse solve with one right-hand side.
States from which no terminal cell can be reached (a deterministic world and a policy that
walks in circles) never end: they are taken out of the solve, and their mass is `never_ends`.
The expected discounted return is V^pi from `planning.policy_evaluation` with the true
rewards, averaged over the start cells; the same for the true optimal policy gives the
baseline the agent is measured against.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from irl_core.support.stopping import stop_if_asked
from irl_core.worlds.mdp import MDP
from irl_core.worlds.planning import policy_evaluation, policy_iteration, policy_matrix


@dataclass(frozen=True)
class Ends:
    """Where episodes of one policy end, from the start distribution.

    Attributes:
        ends: per terminal symbol, the probability that an episode ends in one of its cells.
        never: the probability that an episode never ends (1 - sum of `ends`).
        expected_return: the expected discounted return under the world's true rewards.
    """

    ends: dict[str, float]
    never: float
    expected_return: float


@dataclass(frozen=True)
class Evaluation:
    """An agent that plans for the fitted reward (`agent`) against the true optimum (`optimal`)."""

    agent: Ends
    optimal: Ends

    def to_json(self) -> dict[str, Any]:
        """The fit JSON's ``{"ends": ..., "return": ..., "optimal_return": ...}``, plus the optimum's ends
        and, when some episodes never end, how many."""
        out: dict[str, Any] = {
            "ends": {k: round(v, 6) for k, v in self.agent.ends.items()},
            "return": round(self.agent.expected_return, 4),
            "optimal_return": round(self.optimal.expected_return, 4),
            "optimal_ends": {k: round(v, 6) for k, v in self.optimal.ends.items()},
        }
        if self.agent.never > 1e-9:
            out["never_ends"] = round(self.agent.never, 6)
        return out


def start_distribution(mdp: MDP) -> np.ndarray:
    """(S,) the probability of starting in each state (uniform over the world's start cells)."""
    starts = np.array([mdp.state_of[cell] for cell in mdp.world.start_cells])
    p = np.zeros(mdp.n_states)
    np.add.at(p, starts, 1.0 / starts.size)
    return p


def ending_probabilities(mdp: MDP, actions: np.ndarray, start: np.ndarray) -> np.ndarray:
    """(S,) the probability that the policy `actions` (S,), started from the distribution `start` (S,),
    ends in each state: non-zero only at terminal cells (a start at a terminal cell ends there).

    Solves for y = (I - Q)^-T p_T, one right-hand side, rather than for X = (I - Q)^-1 B: a
    right-hand side per terminal cell (63 on a 64x64 cliff world) and an (S, S) answer.
    """
    P_pi, _ = policy_matrix(mdp, np.asarray(actions))
    P_pi = P_pi.tocsr()
    transient = np.flatnonzero(mdp.nonterminal)
    terminal = np.flatnonzero(mdp.terminal)
    live = transient[_can_end(P_pi, transient, terminal)]
    out = np.zeros(mdp.n_states)
    out[terminal] = start[terminal]
    if live.size and terminal.size:
        Q = P_pi[live][:, live]
        B = P_pi[live][:, terminal]
        y = spla.spsolve((sp.identity(live.size, format="csc") - Q).T.tocsc(), start[live])
        out[terminal] += B.T @ y
    return out


def _can_end(P_pi: sp.csr_matrix, transient: np.ndarray, terminal: np.ndarray) -> np.ndarray:
    """(len(transient),) bool: from which transient states some terminal cell has positive probability."""
    reach = np.zeros(P_pi.shape[0], dtype=bool)
    reach[terminal] = True
    while True:
        step = np.asarray(P_pi[transient] @ reach.astype(float)).ravel() > 0
        new = reach.copy()
        new[transient] |= step
        if (new == reach).all():
            return reach[transient]
        reach = new


def policy_ends(mdp: MDP, actions: np.ndarray) -> Ends:
    """Where the deterministic policy `actions` (S,) ends and its expected return, from the start cells.

    Asks the fit's stop check (`stopping.stop_if_asked`) before each of its two sparse solves and
    after the last.
    """
    start = start_distribution(mdp)
    stop_if_asked()
    reached = ending_probabilities(mdp, actions, start)
    stop_if_asked()
    ends: dict[str, float] = {}
    for s in np.flatnonzero(mdp.terminal):
        symbol = mdp.symbols[s]
        ends[symbol] = ends.get(symbol, 0.0) + float(reached[s])
    expected = float(start @ policy_evaluation(mdp, np.asarray(actions)))
    stop_if_asked()
    return Ends(ends=ends, never=max(0.0, 1.0 - sum(ends.values())), expected_return=expected)


def evaluate(mdp: MDP, fitted_R_S: np.ndarray, *, start: np.ndarray | None = None) -> Evaluation:
    """The agent that plans optimally for `fitted_R_S` (S,), and the true optimum, in the true world.

    Both are planned by policy iteration: the agent from `start` (S,) actions (the fit's own policy, where
    there is one), the optimum from the agent's policy, each a solve or two."""
    agent = policy_iteration(mdp, R_S=np.asarray(fitted_R_S, dtype=float), start=start).greedy
    optimal = policy_iteration(mdp, start=agent).greedy
    return Evaluation(agent=policy_ends(mdp, agent), optimal=policy_ends(mdp, optimal))
