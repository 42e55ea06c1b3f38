"""The world's transitions in direction form against P itself, and the banded solve against SuperLU."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from irl_core.irl.maxent import MAX_BAND, solve_system
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.moves import moves_of
from irl_core.worlds.world import BUILTIN_WORLDS, World

WALLED = World(layout="\n".join(["......", "..#...", ".U#...", "..#...", "......", ".CCCCG"]) + "\n", levels=5,
               rewards={"C": -100.0, "G": 10.0, "U": -3.0})


# Another lab's rules: a fixed split, and moves into a wall dropped (a step's chances then depend on the cell).
WALLED_DROP = WALLED.model_validate({**WALLED.model_dump(), "slip": {"intended": 0.76, "others": [0.09, 0.05, 0.1]},
                                     "bump": "drop"})


@pytest.mark.parametrize("world", [WALLED, WALLED_DROP, BUILTIN_WORLDS["mud-time"], BUILTIN_WORLDS["cliffwalking"]],
                         ids=["walled", "walled-drop", "mud-time", "cliffwalking"])
def test_every_product_in_direction_form_is_the_product_with_P(world):
    mdp = build_mdp(world)
    moves = moves_of(mdp)
    S, A = mdp.n_states, mdp.n_actions
    rng = np.random.default_rng(3)
    X = rng.normal(size=(S, A))
    pi = rng.random((S, A))
    pi /= pi.sum(axis=1, keepdims=True)
    P = mdp.P.toarray().reshape(S, A, S)
    np.testing.assert_allclose(moves.pulled_back(X), np.einsum("sa,sat->t", X, P), atol=1e-12)
    by_hand = np.eye(S) - mdp.gamma * np.einsum("sa,sat->st", pi, P)
    np.testing.assert_allclose(moves.policy_system(pi, gamma=mdp.gamma).toarray(), by_hand, atol=1e-14)


def test_a_narrow_system_is_solved_as_a_band_and_a_wide_one_by_superlu_to_the_same_answer():
    rng = np.random.default_rng(0)
    S = 300
    narrow = sp.diags([rng.random(S - 3), 4 + rng.random(S), rng.random(S - 5)], [-3, 0, 5], format="csc")
    wide = (narrow + sp.csc_matrix(([0.5], ([0], [S - 1])), shape=(S, S))).tocsc()
    assert 3 + 5 <= MAX_BAND < S - 1
    b = rng.normal(size=S)
    for system in (narrow, narrow.T, wide, wide.T):
        np.testing.assert_allclose(solve_system(system, b), spla.spsolve(sp.csc_matrix(system), b), rtol=1e-12)
    # An entry given twice counts twice, as in SuperLU.
    column = 7
    at = narrow.indptr[column]
    data, indices = np.insert(narrow.data, at, 1.0), np.insert(narrow.indices, at, column)
    indptr = narrow.indptr + (np.arange(S + 1) > column)
    twice = sp.csc_matrix((data, indices, indptr), shape=(S, S))
    assert not twice.has_canonical_format
    np.testing.assert_allclose(solve_system(twice, b), spla.spsolve(sp.csc_matrix(twice), b), rtol=1e-12)
    assert not np.allclose(solve_system(twice, b), solve_system(narrow, b))


@pytest.mark.parametrize("world", [WALLED, WALLED_DROP, BUILTIN_WORLDS["cliffwalking"]],
                         ids=["walled", "walled-drop", "cliffwalking"])
def test_a_policy_system_and_its_transpose_solve_from_the_worlds_band_as_dense_lapack_does(world):
    mdp = build_mdp(world)
    S, A = mdp.n_states, mdp.n_actions
    rng = np.random.default_rng(5)
    pi = rng.random((S, A))
    pi /= pi.sum(axis=1, keepdims=True)
    system = moves_of(mdp).policy_system(pi, gamma=mdp.gamma)
    dense = system.toarray()
    assert moves_of(mdp).below + moves_of(mdp).above <= MAX_BAND  # the band route, not SuperLU
    b = rng.normal(size=S)
    np.testing.assert_allclose(solve_system(system, b), np.linalg.solve(dense, b), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(solve_system(system.T, b), np.linalg.solve(dense.T, b), rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(system.T.toarray(), dense.T)
