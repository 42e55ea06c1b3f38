"""The MaxEnt baseline: soft Bellman fixed point, exact gradient, and what the likelihood can see."""

import numpy as np
import pytest
from scipy.special import logsumexp, softmax

from irl_core.irl import FitOptions, fit, maxent
from irl_core.irl.maxent import SoftPlan, log_likelihood, log_likelihood_beta, soft_bellman
from irl_core.players.experts import boltzmann_policy, demonstrations_of, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import soft_value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS, World


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


def change_rule_soft_bellman(mdp, R, *, beta, V0, tol=1e-13, max_iter=200):
    """The soft Bellman route the fast one replaced, as an independent reference: scipy's softmax
    and logsumexp, P^pi by einsum over the dense P, numpy's solve, and a stop when a further
    solve changes V by less than tol (one solve more than the residual rule)."""
    S, A = mdp.n_states, mdp.n_actions
    P = mdp.P.toarray().reshape(S, A, S)
    V = np.zeros(S) if V0 is None else np.asarray(V0, dtype=float)
    for iteration in range(1, max_iter + 1):
        Q = R + mdp.gamma * mdp.expected_next(V)
        pi = softmax(beta * Q, axis=1)
        entropy = -(pi * np.log(np.where(pi > 0, pi, 1.0))).sum(axis=1)
        system = np.identity(S) - mdp.gamma * np.einsum("sa,sat->st", pi, P)
        V_new = np.linalg.solve(system, (pi * R).sum(axis=1) + entropy / beta)
        change, V = float(np.abs(V_new - V).max()), V_new
        if change <= tol * max(1.0, float(np.abs(V).max())):
            Q = R + mdp.gamma * mdp.expected_next(V)
            log_pi = beta * Q - logsumexp(beta * Q, axis=1, keepdims=True)
            return SoftPlan(V=V, Q=Q, policy=np.exp(log_pi), iterations=iteration, log_policy=log_pi)
    raise AssertionError("the reference did not converge")


@pytest.mark.parametrize("gamma", [0.5, 0.95, 0.99])
@pytest.mark.parametrize("beta", [0.05, 1.0, 20.0])
def test_the_residual_rule_gives_the_change_rules_fixed_point(gamma, beta):
    # The residual rule stops at V with max|T(V) - V| <= 1e-13 |V|, so V is within
    # 1e-13 |V| / (1 - gamma) of the fixed point: 1e-11 relative at gamma 0.99.
    mdp, counts, R_S = random_problem(gamma, levels=3, seed=2)
    R_S = R_S * 50  # rewards in hundreds, as a fit's
    plan = soft_bellman(mdp, R_S, beta=beta)
    reference = change_rule_soft_bellman(mdp, mdp.reward_matrix(R_S), beta=beta, V0=None)
    scale = np.abs(reference.V).max()
    np.testing.assert_allclose(plan.V, reference.V, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(plan.policy, reference.policy, rtol=0, atol=1e-9)
    assert plan.iterations < reference.iterations


def test_the_fast_bootstrap_gives_the_intervals_of_the_reference_route(monkeypatch):
    # The whole fit and its bootstrap, once with the fast soft Bellman route and once with the
    # reference: the refits stop at a projected gradient of 1e-5 in unit-curvature variables (a
    # hundred-thousandth of a standard error), so a faster route that moves them by less than that
    # leaves every interval where it was. Tolerance: 1e-6 of the interval's width.
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, boltzmann_policy(mdp, beta=0.3), episodes=10, seed=4))
    options = FitOptions(method="maxent", beta="auto", tie=True, rmax=5000.0, intervals=True, resamples=16)
    fast = fit(demos, options, workers=1)
    monkeypatch.setattr(maxent, "_soft_bellman", change_rule_soft_bellman)
    reference = fit(demos, options, workers=1)
    width = reference.intervals[:, 1] - reference.intervals[:, 0]
    assert (width > 1.0).all()
    np.testing.assert_allclose(fast.intervals, reference.intervals, rtol=0, atol=1e-6 * width.max())
    assert fast.beta == pytest.approx(reference.beta, rel=1e-6)
    np.testing.assert_allclose(fast.theta, reference.theta, rtol=1e-5)


def test_a_big_worlds_policy_system_is_i_minus_gamma_p_pi_built_the_slow_way():
    # policy_system fills its pattern from the moves in direction form; planning.policy_matrix is the independent route.
    import scipy.sparse as sp

    from bench.worlds import cliff_world
    from irl_core.irl.maxent import DENSE_STATES, policy_system
    from irl_core.worlds.mdp import build_mdp
    from irl_core.worlds.planning import policy_matrix

    mdp = build_mdp(cliff_world(12, 14))
    assert mdp.n_states > DENSE_STATES
    pi = np.random.default_rng(0).dirichlet(np.ones(mdp.n_actions), size=mdp.n_states)
    pi[3] = np.eye(mdp.n_actions)[2]  # a deterministic row: zeros in the weights
    expected = sp.identity(mdp.n_states) - mdp.gamma * policy_matrix(mdp, pi)[0]
    assert abs(policy_system(mdp, pi).tocsc() - expected).max() < 1e-14
