"""Planning: the linear solve against iteration, Bellman optimality, soft -> hard, figure 3."""

import numpy as np
import pytest

from irl_core.worlds.mdp import MDP, action_parts, build_mdp
from irl_core.worlds.planning import (
    one_hot,
    policy_evaluation,
    policy_matrix,
    soft_value_iteration,
    value_iteration,
)
from irl_core.worlds.world import BUILTIN_WORLDS, World


@pytest.fixture(scope="module")
def paper():
    return build_mdp(BUILTIN_WORLDS["paper"])


def iterative_policy_evaluation(mdp: MDP, policy: np.ndarray, *, gamma: float, tol: float,
                                max_iter: int = 100_000) -> np.ndarray:
    """(S,) V^pi by repeated expected backups: the slow, independent route to `policy_evaluation`."""
    P_pi, pi = policy_matrix(mdp, policy)
    R_pi = (pi * mdp.reward_matrix()).sum(axis=1)
    V = np.zeros(mdp.n_states)
    for _ in range(max_iter):
        V_new = R_pi + gamma * (P_pi @ V)
        if np.abs(V_new - V).max() < tol:
            return V_new
        V = V_new
    return V


def test_two_state_chain_by_hand():
    # ".G" with a fixed start: from (0, 0) going right with c = 1 reaches G with 1/2,
    # otherwise stays (up, down, left are all off the grid). With gamma = 0.5 and the only
    # action: V0 = -1 + 0.5 (0.5 VG + 0.5 V0), VG = 10  =>  V0 = (-1 + 2.5) / 0.75 = 2.
    world = World(layout=".G\n", levels=1, gamma=0.5, rewards={"G": 10.0})
    mdp = build_mdp(world)
    right = np.full(mdp.n_states, 1)
    V = policy_evaluation(mdp, right)
    assert V[mdp.state_of[(0, 0)]] == pytest.approx(2.0)
    assert V[mdp.state_of[(0, 1)]] == pytest.approx(10.0)
    assert V[mdp.exit_state] == 0.0


@pytest.mark.parametrize("gamma", [0.0, 0.5, 0.9, 0.99])
def test_linear_solve_equals_iterative_evaluation(paper, gamma):
    rng = np.random.default_rng(0)
    policy = rng.dirichlet(np.ones(paper.n_actions), size=paper.n_states)
    np.testing.assert_allclose(policy.sum(axis=1), 1.0)
    exact = policy_evaluation(paper, policy, gamma=gamma)
    iterated = iterative_policy_evaluation(paper, policy, gamma=gamma, tol=1e-12)
    np.testing.assert_allclose(exact, iterated, atol=1e-8)


def test_value_iteration_satisfies_bellman_optimality(paper):
    plan = value_iteration(paper, tol=1e-8)
    assert plan.converged
    backup = (paper.reward_matrix() + paper.gamma * paper.expected_next(plan.V)).max(axis=1)
    assert np.abs(backup - plan.V).max() < 1e-8
    # Its greedy policy's own value is V*.
    np.testing.assert_allclose(policy_evaluation(paper, plan.greedy), plan.V, atol=1e-7)


def test_value_iteration_reports_an_iteration_cap(paper):
    plan = value_iteration(paper, max_iter=3)
    assert plan.iterations == 3 and not plan.converged


def test_soft_value_iteration_tends_to_hard_as_beta_grows(paper):
    hard = value_iteration(paper).V
    for beta in (0.1, 1.0, 10.0, 100.0):
        gap = soft_value_iteration(paper, beta=beta).V - hard
        # A soft maximum exceeds the max by at most log(A)/beta per step, discounted.
        assert gap.min() >= -1e-6
        assert gap.max() <= np.log(paper.n_actions) / (beta * (1 - paper.gamma)) + 1e-6
    assert np.abs(soft_value_iteration(paper, beta=1000.0).V - hard).max() < 0.1


def test_soft_policy_rows_sum_to_one(paper):
    plan = soft_value_iteration(paper, beta=0.1)
    np.testing.assert_allclose(plan.policy.sum(axis=1), 1.0)
    assert plan.converged


def test_ties_go_to_the_lowest_action_index():
    # In a world with no reward anywhere every action is equally good (Q = -cost), so
    # among the cheapest actions (c = 1 in every direction) "up" (index 0) wins.
    mdp = build_mdp(World(layout="...\n", levels=2, cost_per_level=0.0))
    assert (value_iteration(mdp).greedy == 0).all()


def test_optimal_policy_on_paper_matches_figure_3(paper):
    greedy = value_iteration(paper).greedy
    world = paper.world
    cliff = {cell for cell in paper.cells if world.symbol(cell) == "C"}

    def action_at(cell):
        return action_parts(int(greedy[paper.state_of[cell]]), world.levels)

    beside_cliff = [
        cell for cell in world.start_cells
        if any((cell[0] + dr, cell[1] + dc) in cliff for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)))
    ]
    assert beside_cliff and all(action_at(cell)[1] >= 6 for cell in beside_cliff)
    top = max(action_at((0, c))[1] for c in range(world.cols))
    above_cliff = min(action_at((2, c))[1] for c in range(1, 5))
    assert top < above_cliff
    offsets = {"up": (-1, 0), "right": (0, 1), "down": (1, 0), "left": (0, -1)}
    for cell in world.start_cells:
        direction, _ = action_at(cell)
        target = (cell[0] + offsets[direction][0], cell[1] + offsets[direction][1])
        assert target not in cliff, f"{cell} points into the cliff"


def test_one_hot_is_a_policy():
    policy = one_hot(np.array([0, 3, 1]), 4)
    np.testing.assert_allclose(policy.sum(axis=1), 1.0)
    assert policy[1, 3] == 1.0


@pytest.mark.parametrize("name", ["mud", "cliffwalking", "mud-time"])
def test_policy_iteration_finds_value_iterations_optimum_from_nothing_and_from_a_start(name):
    from irl_core.worlds.planning import policy_evaluation, policy_iteration, value_iteration

    mdp = build_mdp(BUILTIN_WORLDS[name])
    swept = value_iteration(mdp, tol=1e-12)
    rng = np.random.default_rng(0)
    for start in (None, swept.greedy, rng.integers(0, mdp.n_actions, mdp.n_states)):
        plan = policy_iteration(mdp, start=start)
        assert plan.converged
        np.testing.assert_allclose(plan.V, swept.V, atol=1e-9)
        # Its policy is worth the optimum, followed exactly.
        np.testing.assert_allclose(policy_evaluation(mdp, plan.greedy), swept.V, atol=1e-9)
    assert policy_iteration(mdp, start=swept.greedy).iterations == 1
