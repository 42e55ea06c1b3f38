"""Sparse against dense value iteration, in the same process.

The dense baseline stores P as an (S, A, S) array and backs up with einsum, as a
textbook implementation would. Run: .venv/bin/python -m bench.bench_planning
"""

from __future__ import annotations

from functools import partial

import numpy as np

from bench.timing import best_of
from bench.worlds import cliff_world
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.planning import value_iteration
from irl_core.worlds.world import BUILTIN_WORLDS


def dense_value_iteration(P: np.ndarray, R: np.ndarray, gamma: float, *, tol: float = 1e-8, max_iter: int = 10_000):
    """V <- max_a R + gamma P V with P: (S, A, S) dense."""
    V = np.zeros(P.shape[0])
    threshold = tol * (1 - gamma) / gamma
    for _ in range(max_iter):
        V_new = (R + gamma * np.einsum("sat,t->sa", P, V)).max(axis=1)
        if np.abs(V_new - V).max() < threshold:
            return V_new
        V = V_new
    return V


def main() -> None:
    print("value iteration, sparse (CSR) against dense (S, A, S) einsum:")
    print(f"  {'world':<10} {'states':>7} {'sparse ms':>10} {'dense ms':>10} {'sparse/dense':>13}")
    for name, world in [("paper", BUILTIN_WORLDS["paper"]), ("16x16", cliff_world(16, 16))]:
        mdp = build_mdp(world)
        P = mdp.P.toarray().reshape(mdp.n_states, mdp.n_actions, mdp.n_states)
        R = mdp.reward_matrix()
        sparse = best_of(3, partial(value_iteration, mdp))
        dense = best_of(1, partial(dense_value_iteration, P, R, mdp.gamma))
        np.testing.assert_allclose(value_iteration(mdp).V, dense_value_iteration(P, R, mdp.gamma), atol=1e-6)
        print(f"  {name:<10} {mdp.n_states:>7} {sparse * 1e3:>10.1f} {dense * 1e3:>10.1f} {sparse / dense:>13.3f}")


if __name__ == "__main__":
    main()
