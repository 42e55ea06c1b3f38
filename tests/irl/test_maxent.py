"""The MaxEnt baseline: soft Bellman fixed point, exact gradient, and what the likelihood can see."""

import numpy as np
import pytest

from irl_core.demonstrations import Demonstrations
from irl_core.experts import boltzmann_policy, rollouts
from irl_core.irl import fit
from irl_core.irl.maxent import log_likelihood, log_likelihood_beta, soft_bellman
from irl_core.mdp import build_mdp
from irl_core.planning import soft_value_iteration
from irl_core.world import BUILTIN_WORLDS, World


def boltzmann_demonstrations(mdp, beta, episodes, seed):
    result = rollouts(mdp, boltzmann_policy(mdp, beta=beta), episodes=episodes, seed=seed)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    return Demonstrations(mdp=mdp, counts=counts, files=0, episodes=episodes, steps=int(counts.sum())), result


@pytest.mark.parametrize("name", ["paper", "paper-maxent"])
@pytest.mark.parametrize("beta", [0.1, 1.0, 5.0])
def test_soft_policy_iteration_matches_soft_value_iteration(name, beta):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    plan = soft_bellman(mdp, mdp.R_S, beta=beta)
    reference = soft_value_iteration(mdp, beta=beta, tol=1e-10)
    np.testing.assert_allclose(plan.V, reference.V, atol=1e-6)
    np.testing.assert_allclose(plan.policy[mdp.nonterminal].sum(axis=1), 1.0)
    assert plan.iterations < 30


def random_problem(gamma, *, levels=2, seed=0):
    """A small world, random counts and a random reward near the true one."""
    world = World(layout="...\n.UG\nC..\n", levels=levels, gamma=gamma, rewards={"C": -20.0, "G": 10.0, "U": -3.0})
    mdp = build_mdp(world)
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 4, size=(mdp.n_states, mdp.n_actions)).astype(float)
    counts[~mdp.nonterminal] = 0.0
    R_S = mdp.R_S + rng.normal(scale=2.0, size=mdp.n_states)
    R_S[mdp.exit_state] = 0.0
    return mdp, counts, R_S


@pytest.mark.parametrize("gamma", [0.0, 0.5, 0.9, 0.99])
def test_gradient_matches_finite_differences(gamma):
    mdp, counts, R_S = random_problem(gamma)
    _, gradient, _ = log_likelihood(mdp, counts, R_S, beta=0.7)
    h = 1e-5
    numeric = np.zeros(mdp.n_states - 1)
    for s in range(mdp.n_states - 1):
        step = np.zeros(mdp.n_states)
        step[s] = h
        up, _, _ = log_likelihood(mdp, counts, R_S + step, beta=0.7)
        down, _, _ = log_likelihood(mdp, counts, R_S - step, beta=0.7)
        numeric[s] = (up - down) / (2 * h)
    np.testing.assert_allclose(gradient[:-1], numeric, rtol=1e-6, atol=1e-6)
    assert gradient[-1] == 0.0


def test_the_exact_soft_optimal_policy_gives_back_mild_rewards():
    world = BUILTIN_WORLDS["paper-maxent"].model_copy(update={"rewards": {"C": -10.0, "G": 10.0}})
    mdp = build_mdp(world)
    policy = soft_value_iteration(mdp, beta=1.0, tol=1e-12).policy
    counts = policy * mdp.nonterminal[:, None]
    demos = Demonstrations(mdp=mdp, counts=counts, files=0, episodes=0, steps=int(mdp.nonterminal.sum()))
    result = fit(demos, method="maxent", beta=1.0)
    truth = result.unknowns.true_theta(mdp)
    np.testing.assert_allclose(result.theta, truth, rtol=0.05)
    assert result.status == "optimal"


@pytest.fixture(scope="module")
def paper_maxent():
    return build_mdp(BUILTIN_WORLDS["paper-maxent"])


def test_beta_0_1_boltzmann_episodes_find_the_goal_but_not_how_bad_the_cliff_is(paper_maxent):
    # The paper's baseline (figure 5): 10,000 soft-optimal episodes at beta 0.1. The expert
    # almost never steps off, so the likelihood goes flat long before the cliff reaches -1000.
    demos, result = boltzmann_demonstrations(paper_maxent, 0.1, 10_000, seed=0)
    fitted = fit(demos, method="maxent", beta=0.1)
    symbols = np.array(fitted.unknowns.symbols)
    assert fitted.theta[symbols == "G"][0] == pytest.approx(100.0, rel=0.2)
    cliff = fitted.theta[symbols == "C"]
    assert np.all(cliff < 0) and np.all(cliff > -500.0)
    assert np.isin(result.final_state, [paper_maxent.state_of[(3, c)] for c in range(1, 5)]).mean() < 0.01


def test_a_soft_optimal_expert_ends_its_episodes(paper_maxent):
    # The entropy bonus accrues after the goal too (the exit is soft as well): otherwise a
    # small-beta expert would wander until the step limit rather than give the bonus up.
    _, result = boltzmann_demonstrations(paper_maxent, 0.1, 2_000, seed=1)
    assert not result.truncated.any()


@pytest.mark.parametrize("gamma", [0.0, 0.9])
def test_beta_gradient_matches_finite_differences(gamma):
    mdp, counts, R_S = random_problem(gamma, levels=3, seed=1)
    beta = 0.7
    ll, grad, grad_log_beta, _ = log_likelihood_beta(mdp, counts, R_S, beta=beta)
    h = 1e-6
    up, _, _ = log_likelihood(mdp, counts, R_S, beta=beta * np.exp(h))
    down, _, _ = log_likelihood(mdp, counts, R_S, beta=beta * np.exp(-h))
    assert grad_log_beta == pytest.approx((up - down) / (2 * h), rel=1e-5, abs=1e-6)
    # The R_S part is the fixed-beta gradient.
    same_ll, same_grad, _ = log_likelihood(mdp, counts, R_S, beta=beta)
    assert ll == pytest.approx(same_ll) and np.allclose(grad, same_grad)
