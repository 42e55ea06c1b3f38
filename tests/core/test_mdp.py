"""The MDP: transition rows, slip probabilities worked by hand, the absorbing exit."""

import numpy as np
import pytest

from irl_core.worlds.mdp import action_index, action_parts, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World


def dense(mdp):
    return mdp.P.toarray().reshape(mdp.n_states, mdp.n_actions, mdp.n_states)


@pytest.mark.parametrize("name", list(BUILTIN_WORLDS))
def test_every_transition_row_sums_to_one(name):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    np.testing.assert_allclose(np.asarray(mdp.P.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    assert (mdp.P.data >= 0).all()


def test_action_index_is_d_times_L_plus_c_minus_1():
    assert action_index("up", 1, 14) == 0
    assert action_index("right", 5, 14) == 14 + 4
    assert action_index("left", 14, 14) == 55
    assert all(action_parts(action_index(d, c, 3), 3) == (d, c) for d in ("up", "left") for c in (1, 2, 3))


def test_corridor_1x3_by_hand():
    # Cells 0 1 2 in a row. From the middle with "right" at carefulness c: right with
    # 1 - 2^-c, left with 2^-c/3, and up/down (off the grid) leave it in place: 2 * 2^-c/3.
    mdp = build_mdp(World(layout="...\n", levels=3))
    P = dense(mdp)
    for c in (1, 2, 3):
        row = P[1, action_index("right", c, 3)]
        slip = 2.0**-c / 3
        np.testing.assert_allclose(row[:3], [slip, 2 * slip, 1 - 2.0**-c], atol=1e-15)
    # From the left end going left: off the grid, so it stays with 1 - 2^-c + 2 * slip.
    row = P[0, action_index("left", 1, 3)]
    np.testing.assert_allclose(row[:3], [1 - 0.5 + 2 * 0.5 / 3, 0.5 / 3, 0.0])


def test_cell_beside_a_wall_by_hand():
    # . # .
    # . . .   from (1, 1) going up at c = 2: up is a wall, so "stay" gets 3/4;
    # right, down (off the grid -> stay) and left each get 1/12.
    world = World(layout=".#.\n...\n", levels=2)
    mdp = build_mdp(world)
    P = dense(mdp)
    s = mdp.state_of[(1, 1)]
    row = P[s, action_index("up", 2, 2)]
    assert row[s] == pytest.approx(0.75 + 1 / 12)
    assert row[mdp.state_of[(1, 2)]] == pytest.approx(1 / 12)
    assert row[mdp.state_of[(1, 0)]] == pytest.approx(1 / 12)
    assert (1, 0) in mdp.state_of and (0, 1) not in mdp.state_of  # a wall is not a state


def test_no_slip_world_is_deterministic():
    mdp = build_mdp(BUILTIN_WORLDS["paper-maxent"])
    P = dense(mdp)
    s = mdp.state_of[(0, 0)]
    assert P[s, action_index("right", 1, 1), mdp.state_of[(0, 1)]] == 1.0


def test_terminal_cells_lead_to_an_absorbing_exit_with_zero_reward():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    P = dense(mdp)
    cliff, exit_ = mdp.state_of[(3, 1)], mdp.exit_state
    assert (P[cliff, :, exit_] == 1.0).all() and (P[exit_, :, exit_] == 1.0).all()
    R = mdp.reward_matrix()
    assert (R[exit_] == 0.0).all()
    assert (R[cliff] == -1000.0).all()  # the terminal reward, with no action cost
    ground = mdp.state_of[(0, 0)]
    assert R[ground, action_index("down", 5, 14)] == -5.0  # R_S = 0 plus R_A = -1 * c


def test_mud_is_not_terminal_and_costs_every_step():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    mud = mdp.state_of[(1, 1)]
    assert mdp.nonterminal[mud]
    assert mdp.reward_matrix()[mud, action_index("up", 2, 14)] == -32.0


def test_large_world_builds_sparsely():
    layout = "\n".join(["." * 64] * 63 + ["." + "C" * 62 + "G"]) + "\n"
    mdp = build_mdp(World(layout=layout, levels=14, rewards={"C": -1000.0, "G": 100.0}))
    assert mdp.P.shape == (4097 * 56, 4097)
    assert mdp.P.nnz < 5 * 4097 * 56  # a few entries per row, not S per row
