"""The environment is usable: tabular Q-learning on `paper` learns to be careful at the cliff.

The learnt greedy policy is judged exactly, not by sampling: its episodes are an absorbing
Markov chain over the MDP, propagated for the world's step limit from the start distribution.
"""

import numpy as np

from irl_core.worlds.env import CarefulEnv, cell_observation
from irl_core.worlds.mdp import MDP
from irl_core.worlds.planning import policy_matrix


def ending_probabilities(mdp: MDP, actions: np.ndarray) -> dict[str, float]:
    """P(the episode ends in a cell with each terminal symbol) for actions (S,), within max_steps."""
    P_pi, _ = policy_matrix(mdp, actions)
    step = P_pi.T.tocsr()
    mass = np.zeros(mdp.n_states)
    starts = [mdp.state_of[cell] for cell in mdp.world.start_cells]
    mass[starts] = 1.0 / len(starts)
    ended = np.zeros(mdp.n_states)
    for _ in range(mdp.world.max_steps):
        mass = step @ mass
        ended += np.where(mdp.terminal, mass, 0.0)
        mass = np.where(mdp.nonterminal, mass, 0.0)
    symbols = np.array([*mdp.symbols, ""])
    return {symbol: float(ended[symbols == symbol].sum()) for symbol in mdp.world.terminal}


def q_learning(env: CarefulEnv, *, episodes: int, seed: int, alpha=0.1, epsilon=0.2) -> np.ndarray:
    """(n_observations, n_actions) Q from epsilon-greedy one-step Q-learning."""
    rng = np.random.default_rng(seed)
    Q = np.zeros((env.observation_space.n, env.action_space.n))
    gamma = env.world.gamma
    env.reset(seed=seed)
    for _ in range(episodes):
        obs, _ = env.reset()
        done = False
        while not done:
            a = int(rng.integers(Q.shape[1])) if rng.random() < epsilon else int(Q[obs].argmax())
            nxt, reward, terminated, truncated, _ = env.step(a)
            target = reward + (0.0 if terminated else gamma * Q[nxt].max())
            Q[obs, a] += alpha * (target - Q[obs, a])
            obs, done = nxt, terminated or truncated
    return Q


def greedy_actions(env: CarefulEnv, Q: np.ndarray) -> np.ndarray:
    """(S,) the greedy action in each MDP state (the exit's is irrelevant)."""
    cols = env.world.cols
    return np.array([Q[cell_observation(cell, cols)].argmax() for cell in env.mdp.cells] + [0])


def test_q_learning_learns_to_avoid_the_cliff_on_paper():
    env = CarefulEnv("paper")
    mdp, L = env.mdp, env.world.levels
    learnt = greedy_actions(env, q_learning(env, episodes=2000, seed=0))
    ends = ending_probabilities(mdp, learnt)
    assert ends["C"] < 0.05
    assert ends["G"] > 0.95

    # The same routes walked at carefulness 1 fall far more often: the care was learnt too.
    careless = learnt - learnt % L
    assert ending_probabilities(mdp, careless)["C"] > 0.2
    # And the untrained greedy policy (up, carefulness 1, everywhere) falls more often than not.
    assert ending_probabilities(mdp, np.zeros(mdp.n_states, dtype=int))["C"] > 0.5
