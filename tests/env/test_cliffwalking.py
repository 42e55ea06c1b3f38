"""The built-in `cliffwalking` world is Gymnasium's CliffWalking layout, so code written for it reads ours."""

import gymnasium as gym
import numpy as np

from irl_core.worlds.env import CarefulEnv
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS

WORLD = BUILTIN_WORLDS["cliffwalking"]


def test_its_layout_start_and_goal_are_gymnasiums():
    theirs = gym.make("CliffWalking-v1").unwrapped
    assert (WORLD.rows, WORLD.cols) == theirs.shape
    cliff = np.array([[ch == "C" for ch in row] for row in WORLD.grid])
    assert np.array_equal(cliff, theirs._cliff)
    ours = CarefulEnv(WORLD)
    obs, _ = ours.reset(seed=0)
    assert obs == theirs.start_state_index == 36
    goal = [(r, c) for r, row in enumerate(WORLD.grid) for c, ch in enumerate(row) if ch == "G"]
    assert goal == [(3, 11)]


def test_the_shortest_walk_scores_what_it_scores_in_gymnasium():
    # Up, eleven steps right, down: 13 steps at -1 each, the goal worth nothing more.
    walk = [0] + [1] * 11 + [2]
    theirs = gym.make("CliffWalking-v1")
    theirs.reset(seed=0)
    their_return = sum(theirs.step(a)[1] for a in walk)
    world = WORLD.model_copy(update={"slip": "none"})
    ours = CarefulEnv(world)
    ours.reset(seed=0)
    levels = world.levels
    steps = [ours.step(d * levels) for d in walk]  # carefulness 1: a = d * L
    assert their_return == sum(step[1] for step in steps) == -13
    assert steps[-1][2] and not any(step[2] for step in steps[:-1])


def test_stepping_off_the_edge_ends_the_episode_here_not_there():
    ours = CarefulEnv(WORLD.model_copy(update={"slip": "none"}))
    ours.reset(seed=0)
    _, reward, terminated, _, _ = ours.step(1 * WORLD.levels)  # right, into the cliff
    assert terminated and reward == -101  # the move's -1 and the cliff's -100
    theirs = gym.make("CliffWalking-v1")
    theirs.reset(seed=0)
    obs, reward, terminated, _, _ = theirs.step(1)
    assert (obs, reward, terminated) == (36, -100, False)  # back to the start, the episode goes on


def test_a_careful_expert_walks_further_from_the_edge_than_a_careless_one():
    # The point of the world: with slips, the optimal policy pays for care next to the cliff.
    mdp = build_mdp(WORLD)
    plan = value_iteration(mdp)
    next_to_cliff = mdp.state_of[(2, 5)]
    far_from_it = mdp.state_of[(0, 5)]
    level = lambda s: int(np.argmax(plan.policy[s])) % WORLD.levels + 1  # noqa: E731
    assert level(next_to_cliff) > level(far_from_it)
