"""The simple IRL agent (lp): its constraints, its solution and what carefulness buys."""

import numpy as np
import pytest

from careful_tui.option_words import said
from irl_core.irl import InfeasibleError, fit
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.players.experts import optimal_policy, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import action_index, build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS, World


def demonstrations(mdp, counts, episodes=1):
    return Demonstrations(mdp=mdp, counts=counts, files=1, episodes=episodes, steps=int(counts.sum()))


def optimal_demonstrations(name, episodes, seed):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    result = rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    return demonstrations(mdp, counts, episodes)


@pytest.mark.parametrize("reward_cells", ["special", "all"])
def test_true_reward_with_optimal_values_satisfies_every_constraint(reward_cells):
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    plan = value_iteration(mdp, tol=1e-12)
    policy = np.where(mdp.nonterminal, plan.greedy, -1)
    unknowns = build_unknowns(mdp, reward_cells=reward_cells)
    qmap = build_qmap(mdp, unknowns)
    constraints = lp_constraints(qmap, policy, rmax=1000.0)
    x = qmap.join(unknowns.true_theta(mdp), plan.V)
    assert constraints.violation(x) <= 1e-8
    # ... and the constraints are not vacuous: a reward without the cliff breaks them.
    theta = unknowns.true_theta(mdp)
    theta[np.array([label.startswith("C") for label in unknowns.labels])] = 0.0
    safe = value_iteration(mdp, R_S=unknowns.state_rewards(theta))
    assert constraints.violation(qmap.join(theta, safe.V)) > 1.0


def test_with_every_state_demonstrated_v_is_the_policys_value():
    world = World(layout="....\n.C.G\n", levels=3, rewards={"C": -50.0, "G": 20.0})
    mdp = build_mdp(world)
    pi = value_iteration(mdp).greedy
    assert len({int(a) for a in pi[mdp.nonterminal]}) > 1, "the policy should not be constant"
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    acting = np.flatnonzero(mdp.nonterminal)
    counts[acting, pi[acting]] = 1.0
    result = fit(demonstrations(mdp, counts), method="lp")

    # P^pi row by row from pi(s), and R^pi, under the fitted reward.
    P = mdp.P.toarray()
    R = mdp.reward_matrix(result.R_S)
    P_pi = np.vstack([P[s * mdp.n_actions + pi[s]] for s in range(mdp.n_states)])
    R_pi = np.array([R[s, pi[s]] for s in range(mdp.n_states)])
    V_pi = np.linalg.solve(np.eye(mdp.n_states) - mdp.gamma * P_pi, R_pi)
    np.testing.assert_allclose(result.V, V_pi, atol=1e-6)


@pytest.fixture(scope="module")
def paper_100():
    return optimal_demonstrations("paper", 100, seed=0)


def test_carefulness_pins_the_cliff_and_the_goal(paper_100):
    result = fit(paper_100, method="lp")
    labels = list(result.labels)
    cliff = result.theta[[i for i, label in enumerate(labels) if label.startswith("C")]]
    goal = result.theta[labels.index("G (3, 5)")]
    assert cliff.size == 4
    np.testing.assert_array_less(np.abs(cliff + 1000.0), 100.0)
    assert abs(goal - 100.0) < 20.0
    doubled = fit(paper_100, method="lp", rmax=2000.0)
    assert np.max(np.abs(doubled.theta - result.theta) / np.abs(result.theta)) < 0.05


def test_without_carefulness_the_answer_follows_rmax():
    demos = optimal_demonstrations("paper-simple", 100, seed=0)
    base, doubled = fit(demos, method="lp").theta, fit(demos, method="lp", rmax=2000.0).theta
    assert np.max(np.abs(doubled - base) / np.abs(base)) > 0.5


def test_lambda_trades_margin_for_a_smaller_reward(paper_100):
    plain, sparse = fit(paper_100, method="lp"), fit(paper_100, method="lp", lam=1.0)
    assert np.abs(sparse.theta).sum() < np.abs(plain.theta).sum()


def test_demonstrations_optimal_for_no_reward_are_infeasible():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    # Walking into the top-left corner's wall at the highest level: costly and pointless.
    counts[mdp.state_of[(0, 0)], action_index("up", 14, mdp.levels)] = 5.0
    with pytest.raises(InfeasibleError, match='method="loss"') as raised:
        fit(demonstrations(mdp, counts), method="lp", rmax=10_000.0)
    # No bound would make walking into a wall optimal, so the advice is another method, not a larger rmax.
    assert raised.value.code == "infeasible" and "however large" in said(raised.value)
    assert "--method loss" in said(raised.value) and "--rmax" not in said(raised.value)
