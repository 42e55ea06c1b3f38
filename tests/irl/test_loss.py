"""The loss IRL agent: convex as cvxpy sees it, solved exactly, reproducible when not unique."""

import itertools

import cvxpy as cp
import numpy as np
import pytest

from careful_tui.option_words import said
from irl_core.irl import fit
from irl_core.irl.loss.model import loss_constraints, loss_problem, relu_terms
from irl_core.irl.loss.solve import fit_loss
from irl_core.irl.qmap import QMap, build_qmap, build_unknowns
from irl_core.players.experts import boltzmann_policy, demonstrations_of, optimal_policy, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import action_index, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def loss_value(qmap: QMap, frequencies: np.ndarray, x: np.ndarray, *, lam: float = 0.0) -> float:
    """L(R_S) at x = [theta; V], evaluated directly with numpy."""
    z = relu_terms(qmap, frequencies, x)
    theta, _ = qmap.split(x)
    return float(np.exp(np.maximum(z, 0.0)).sum() + lam * qmap.unknowns.weight @ np.abs(theta))



def demonstrations(name, policy, episodes, seed):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    pi = optimal_policy(mdp) if policy == "optimal" else boltzmann_policy(mdp, beta=policy)
    result = rollouts(mdp, pi, episodes=episodes, seed=seed)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    return Demonstrations(mdp=mdp, counts=counts, files=1, episodes=episodes, steps=int(counts.sum()))


def qmap_of(demos, **options):
    return build_qmap(demos.mdp, build_unknowns(demos.mdp, **options))


@pytest.mark.parametrize("lam", [0.0, 0.5])
def test_cvxpy_accepts_the_loss_as_convex(lam):
    demos = demonstrations("paper", 1.0, 10, 0)
    problem, _ = loss_problem(loss_constraints(qmap_of(demos), demos.policy, rmax=1000.0), lam=lam)
    assert problem.is_dcp()
    assert problem.objective.expr.curvature == "CONVEX"


@pytest.mark.parametrize("seed", range(5))
def test_noisy_boltzmann_demonstrations_put_the_cliff_below_the_goal(seed):
    result = fit(demonstrations("paper", 1.0, 10, seed), method="loss")
    assert result.status == "optimal"
    cliff = result.theta[np.array(result.unknowns.symbols) == "C"]
    goal = result.theta[np.array(result.unknowns.symbols) == "G"]
    assert cliff.mean() < goal.mean()


# Clarabel stops with "insufficient progress" on some instances (paper seeds 0-2); these it solves.
@pytest.mark.parametrize("name, seed", [("paper", 3), ("paper", 4), ("mud", 0)])
def test_the_minimum_matches_an_independent_conic_solve(name, seed):
    demos = demonstrations(name, 1.0, 10, seed)
    qmap = qmap_of(demos)
    ours = fit_loss(qmap, demos.policy, rmax=1000.0)
    problem, _ = loss_problem(loss_constraints(qmap, demos.policy, rmax=1000.0))
    problem.solve(solver=cp.CLARABEL)
    assert problem.status == cp.OPTIMAL
    assert ours.lower_bound <= ours.loss <= ours.lower_bound * (1 + 1e-7)
    assert ours.loss == pytest.approx(problem.value, rel=1e-6)


def test_relu_terms_follow_the_definition():
    demos = demonstrations("mud", 1.0, 5, 3)
    qmap = qmap_of(demos)
    rng = np.random.default_rng(1)
    x = rng.normal(scale=50.0, size=qmap.n)
    Q, pi = qmap.q(x), demos.policy
    expected = [
        sum(pi[s, a] * (max(Q[s, b] for b in range(Q.shape[1]) if b != a) - Q[s, a]) for a in range(Q.shape[1]))
        for s in np.flatnonzero(demos.demonstrated)
    ]
    np.testing.assert_allclose(relu_terms(qmap, pi, x), expected, atol=1e-9)


def test_the_model_constraints_hold_at_the_answer():
    demos = demonstrations("mud", 1.0, 10, 2)
    qmap = qmap_of(demos)
    solution = fit_loss(qmap, demos.policy, rmax=1000.0)
    Q = qmap.q(solution.x)
    theta, V = qmap.split(solution.x)
    shown = demos.demonstrated
    np.testing.assert_allclose(V[shown], (demos.policy * Q).sum(axis=1)[shown], atol=1e-6)
    free = demos.mdp.nonterminal & ~shown
    assert np.all(V[free, None] >= Q[free] - 1e-6)
    assert np.all(np.abs(theta) <= 1000.0 + 1e-9)


def test_clean_demonstrations_reach_the_floor_and_are_reported_not_unique():
    demos = demonstrations("paper-simple", "optimal", 100, 0)
    result = fit(demos, method="loss")
    assert any(str(note).startswith("not unique") for note in result.notes)
    again = fit(demos, method="loss")
    np.testing.assert_array_equal(result.theta, again.theta)
    shown = demos.demonstrated.sum()
    assert loss_value(build_qmap(demos.mdp, result.unknowns), demos.policy, np.concatenate([result.theta, result.V])) == \
        pytest.approx(shown)


def test_at_the_floor_the_reported_minimiser_has_the_smallest_l1_norm():
    # At the floor (every z_s <= 0) the minimisers are exactly the feasible points with z <= 0:
    # a polyhedron, so the smallest ||R_S||_1 among them is an LP we can solve independently.
    demos = demonstrations("paper-simple", "optimal", 100, 0)
    qmap = qmap_of(demos)
    solution = fit_loss(qmap, demos.policy, rmax=1000.0)
    assert solution.loss == pytest.approx(demos.demonstrated.sum())
    c = loss_constraints(qmap, demos.policy, rmax=1000.0)
    lp = c.program
    y = cp.Variable(lp.shape[1])
    eq, bounded = lp.row_lower == lp.row_upper, np.isfinite(lp.lower)
    reference = cp.Problem(
        cp.Minimize(qmap.unknowns.weight @ cp.abs(y[: qmap.k])),
        [lp.A[eq] @ y == lp.row_lower[eq], lp.A[~eq] @ y <= lp.row_upper[~eq],
         y[bounded] >= lp.lower[bounded], y[bounded] <= lp.upper[bounded], c.Z @ y + c.z0 <= 0],
    )
    reference.solve(solver=cp.HIGHS)
    ours = qmap.unknowns.weight @ np.abs(solution.x[: qmap.k])
    assert ours == pytest.approx(reference.value, rel=1e-6, abs=1e-6)


def test_huge_bounds_do_not_overflow():
    demos = demonstrations("paper", 1.0, 10, 4)
    result = fit(demos, method="loss", rmax=1e6, lam=0.1)
    assert np.all(np.isfinite(result.theta)) and result.status == "optimal"


@pytest.mark.parametrize("reward_cells, tie", itertools.product(["special", "all"], [False, True]))
def test_every_unknown_layout_solves(reward_cells, tie):
    result = fit(demonstrations("mud", 1.0, 10, 0), method="loss", reward_cells=reward_cells, tie=tie)
    assert result.status == "optimal" and np.all(np.isfinite(result.R_S))


@pytest.mark.parametrize("rmax", [1000.0, 1e6])
def test_absurd_demonstrations_give_a_huge_loss_without_overflow(rmax):
    # Walking into walls at the highest level: every reward leaves z_s in the hundreds (e^230).
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    for cell, direction, level in (((0, 0), "up", 14), ((0, 1), "left", 14), ((2, 1), "down", 1), ((2, 3), "right", 3)):
        counts[mdp.state_of[cell], action_index(direction, level, mdp.levels)] = 5.0
    demos = Demonstrations(mdp=mdp, counts=counts, files=1, episodes=1, steps=20)
    qmap = qmap_of(demos)
    solution = fit_loss(qmap, demos.policy, rmax=rmax, lam=1.0)
    z = relu_terms(qmap, demos.policy, solution.x)
    assert z.max() > 200 and np.all(np.isfinite(solution.x))
    assert solution.gap < 1e-4


def test_a_loss_minimiser_that_is_not_unique_gets_no_confidence_interval():
    """A deterministic expert's loss is at its floor for a whole set of rewards; resampling it
    only moves the smallest-||R_S||_1 pick (on mud: zero-width intervals that miss the cliff's
    -1000), which is no confidence interval for the reward."""
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=40, seed=0))
    result = fit(demos, method="loss", intervals=True, resamples=20, workers=1)
    assert any(str(note).startswith("not unique") for note in result.notes)
    assert result.intervals is None and result.interval_kind is None
    # The command line says the option to try as its flags (the library as fit's parameters).
    assert any(note.code == "intervals_not_computed" and "--method lp --intervals" in said(note)
               for note in result.notes)
