"""The lp fit's first round starts from a policy's vertex (`lp.start_from_policy`)."""

from __future__ import annotations

import numpy as np
import pytest

import irl_core.irl.lp.solve as lp
from bench.worlds import cliff_world
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

RMAX = 1000.0


def margin_problem(world, *, episodes=100, tie=False):
    mdp = build_mdp(world)
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=0))
    constraints = lp_constraints(build_qmap(mdp, build_unknowns(mdp, tie=tie)), demos.most_frequent, rmax=RMAX)
    return constraints, lp.margin_lp(constraints)


def test_the_expert_aims_at_the_goal_and_at_no_cliff_cell():
    _, problem = margin_problem(BUILTIN_WORLDS["mud"])
    aimed = lp.aimed_unknowns(problem)
    symbols = np.array(problem.qmap.unknowns.symbols)
    assert aimed[symbols == "G"].all() and not aimed[symbols == "C"].any() and not aimed[symbols == "U"].any()


def test_the_start_is_the_policy_s_own_vertex():
    # Checked through the Q map (the LP's own rows), not the policy evaluation that built it.
    _, problem = margin_problem(BUILTIN_WORLDS["mud"])
    theta, V, policy = lp.policy_vertex(problem)
    qmap, mdp = problem.qmap, problem.qmap.mdp
    Q = qmap.q(np.concatenate([theta, V]))
    shown, free = problem.demonstrated, np.flatnonzero(mdp.nonterminal & (problem.policy < 0))
    assert set(np.unique(theta)) <= {-RMAX, RMAX}
    np.testing.assert_allclose(V[shown], Q[shown, problem.policy[shown]], atol=1e-9)
    # Policy iteration converged on mud: elsewhere the policy's action is the best one.
    np.testing.assert_allclose(V[free], Q[free].max(axis=1), atol=1e-9)
    np.testing.assert_allclose(qmap.E @ np.concatenate([theta, V]), qmap.e, atol=1e-9)


def test_the_start_cuts_the_first_round_and_keeps_the_optimum():
    constraints, problem = margin_problem(cliff_world(32, 32))
    started = lp.solve_margin_lp(constraints)
    plain = lp.RowGeneration(problem, options=lp.margin_options(problem))
    z = plain.solve()
    # HiGHS is deterministic: 1,477 iterations from the start against 3,918 and more without.
    assert started.iterations < plain.model.iterations / 2
    assert started.margin == pytest.approx(z[problem.qmap.n:problem.qmap.n + problem.demonstrated.size].sum(),
                                           rel=1e-7)


def test_a_tied_fit_keeps_highs_own_start(monkeypatch):
    used = []
    monkeypatch.setattr(lp, "start_from_policy", lambda run, **_: used.append(run))
    for tie in (False, True):
        lp.solve_margin_lp(margin_problem(BUILTIN_WORLDS["mud"], tie=tie)[0])
    assert len(used) == 1 and not lp.shares_terminal_unknowns(used[0].problem)

