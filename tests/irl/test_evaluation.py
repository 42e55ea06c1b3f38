"""`evaluation`: an agent trained on a fitted reward, evaluated exactly in the true world."""

import numpy as np
import pytest

from irl_core.irl.evaluation import evaluate, policy_ends
from irl_core.players.experts import rollouts
from irl_core.worlds.mdp import action_index, build_mdp
from irl_core.worlds.planning import one_hot, value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS, World

CORRIDOR = World(name="corridor", layout="C.G\n", levels=2, start=(0, 1), rewards={"C": -100.0, "G": 10.0})


@pytest.mark.parametrize(("level", "goal"), [(1, 3 / 4), (2, 9 / 10)])
def test_a_corridor_with_a_cliff_by_hand(level, goal):
    # From the middle, right at level c moves right with probability 1 - 2^-c and each other way with
    # 2^-c / 3: left is the cliff, up and down stay. So P(goal) = (1 - 2^-c) / (1 - 2 * 2^-c / 3):
    # 3/4 at level 1, 9/10 at level 2.
    mdp = build_mdp(CORRIDOR)
    actions = np.full(mdp.n_states, action_index("right", level, mdp.levels))
    ends = policy_ends(mdp, actions)
    assert ends.ends == pytest.approx({"C": 1 - goal, "G": goal})
    assert ends.never == pytest.approx(0.0, abs=1e-12)
    # V(middle) = -c + gamma (P(G) 10 + P(C) (-100) + P(stay) V(middle)), one step at a time.
    p = 2.0**-level / 3
    stay = 2 * p
    value = (-level + 0.95 * ((1 - 3 * p) * 10 + p * -100)) / (1 - 0.95 * stay)
    assert ends.expected_return == pytest.approx(value)


def test_the_true_reward_is_its_own_optimum_and_a_wrong_one_is_worse():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    own = evaluate(mdp, mdp.R_S)
    assert own.agent == own.optimal
    careless = mdp.R_S.copy()
    careless[np.array([s == "C" for s in mdp.symbols] + [False])] = -1.0  # the cliff barely matters
    worse = evaluate(mdp, careless)
    assert worse.agent.ends["C"] > own.agent.ends["C"]
    assert worse.agent.expected_return < own.optimal.expected_return
    data = worse.to_json()
    assert set(data) >= {"ends", "return", "optimal_return"} and set(data["ends"]) == {"C", "G"}


def test_a_policy_that_walks_in_circles_never_ends():
    world = World(name="loop", layout="..\n.G\n", levels=1, slip="none", start=(0, 0), rewards={"G": 1.0})
    mdp = build_mdp(world)
    actions = np.full(mdp.n_states, action_index("up", 1, 1))  # bumps into the top edge for ever
    ends = policy_ends(mdp, actions)
    assert ends.ends == {"G": 0.0} and ends.never == pytest.approx(1.0)


def test_exact_ends_agree_with_monte_carlo_rollouts():
    mdp = build_mdp(BUILTIN_WORLDS["mud-simple"])
    fitted = mdp.R_S.copy()
    fitted[np.array([s == "U" for s in mdp.symbols] + [False])] = 0.0  # an agent that ignores the mud
    actions = value_iteration(mdp, R_S=fitted).greedy
    exact = policy_ends(mdp, actions)
    episodes = 20_000
    result = rollouts(mdp, one_hot(actions, mdp.n_actions), episodes=episodes, seed=5, max_steps=5_000)
    assert not result.truncated.any()
    for symbol, p in exact.ends.items():
        share = np.mean([mdp.symbols[s] == symbol for s in result.final_state])
        error = np.sqrt(p * (1 - p) / episodes)
        assert abs(share - p) <= 3 * error, (symbol, share, p)
