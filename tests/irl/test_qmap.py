"""The shared Q map: Q = M x + q0 reproduces planning's Q, and the unknowns follow README "Fitting a reward"."""

import numpy as np
import pytest

from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS, World


@pytest.fixture(scope="module")
def paper():
    return build_mdp(BUILTIN_WORLDS["paper"])


@pytest.mark.parametrize("reward_cells", ["special", "all"])
@pytest.mark.parametrize("tie", [False, True])
def test_q_map_at_the_true_reward_and_v_star_is_plannings_q(paper, reward_cells, tie):
    unknowns = build_unknowns(paper, reward_cells=reward_cells, tie=tie)
    qmap = build_qmap(paper, unknowns)
    plan = value_iteration(paper)
    x = qmap.join(unknowns.true_theta(paper), plan.V)
    np.testing.assert_allclose(qmap.q(x), plan.Q, atol=1e-8)
    np.testing.assert_allclose(qmap.E @ x, qmap.e, atol=1e-8)
    np.testing.assert_allclose(unknowns.state_rewards(unknowns.true_theta(paper)), paper.R_S)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 0.9, 0.99])
def test_q_map_matches_the_bellman_backup_for_any_values(gamma):
    world = World(layout="..#.\n.CUG\n", levels=3, gamma=gamma, rewards={"C": -50.0, "G": 10.0, "U": -3.0})
    mdp = build_mdp(world)
    unknowns = build_unknowns(mdp, reward_cells="all")
    qmap = build_qmap(mdp, unknowns)
    rng = np.random.default_rng(0)
    theta, V = rng.normal(size=unknowns.k), rng.normal(size=mdp.n_states)
    R_S = unknowns.state_rewards(theta)
    expected = mdp.reward_matrix(R_S) + gamma * mdp.expected_next(V)
    np.testing.assert_allclose(qmap.q(qmap.join(theta, V)), expected, atol=1e-12)


def test_unknowns_special_all_and_tied(paper):
    special = build_unknowns(paper)
    assert special.labels == ("C (3, 1)", "C (3, 2)", "C (3, 3)", "C (3, 4)", "G (3, 5)")
    assert special.mask.sum() == 5 and not special.mask[paper.exit_state]
    tied = build_unknowns(paper, tie=True)
    assert tied.labels == ("C", "G") and list(tied.weight) == [4.0, 1.0]
    every = build_unknowns(paper, reward_cells="all")
    assert every.k == len(paper.cells)
    assert build_unknowns(paper, reward_cells="all", tie=True).labels == (".", "C", "G")


def test_value_bound_holds_for_the_optimal_values(paper):
    qmap = build_qmap(paper, build_unknowns(paper))
    assert np.abs(value_iteration(paper).V).max() <= qmap.value_bound(1000.0)
