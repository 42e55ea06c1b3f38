"""Every way the lp is solved gives the full LP's answer.

The margin by row generation (the default), by the whole slack-form LP and by the interior
point method (big worlds' route) are compared with the paper's own epigraph form, built here independently and solved whole by scipy's dual simplex;
the intervals by the explicit dual with a fresh primal LP per end. Infeasible demonstrations
must be reported infeasible by every route.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from bench.worlds import cliff_world
from irl_core.irl import InfeasibleError, fit
from irl_core.irl.intervals.identified import reward_intervals
from irl_core.irl.lp.margin import lp_constraints, margin_lp
from irl_core.irl.lp.solve import margin_options, solve_margin_lp
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS, World

RMAX = 1000.0
WALLED = World(name="walled", layout="..#..\n.#...\n...#.\n.C.UG\n", levels=4, rewards={"C": -100.0, "U": -5.0, "G": 10.0})


def world_named(name):
    if name == "walled":
        return WALLED
    if name.startswith("cliff-"):
        size = int(name.split("-")[1])
        return cliff_world(size, size)
    return BUILTIN_WORLDS[name]


def constraints_for(world, *, episodes, seed=0, tie=False):
    mdp = build_mdp(world)
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed))
    return lp_constraints(build_qmap(mdp, build_unknowns(mdp, tie=tie)), demos.most_frequent, rmax=RMAX)


def epigraph_margin(constraints, lam=0.0):
    """The paper's objective, margin - lambda ||R_S||_1, with t_s >= Q(s, a) (a != pi(s)), solved whole by scipy.

    Over [x; t (d); u (k)]: minimise -sum V(s) + sum t_s + lambda w @ u. Returns the margin, or
    None when scipy finds it infeasible.
    """
    qmap, policy, program = constraints.qmap, constraints.policy, constraints.program
    n, k, A = qmap.n, qmap.k, qmap.mdp.n_actions
    d = constraints.demonstrated
    s_rep, a_rep = np.repeat(d, A), np.tile(np.arange(A), d.size)
    other = a_rep != policy[s_rep]
    rows_q, q0 = qmap.rows(s_rep[other], a_rep[other])
    t_of = np.searchsorted(d, s_rep[other])
    pick_t = sp.csr_matrix((np.ones(t_of.size), (np.arange(t_of.size), t_of)), shape=(t_of.size, d.size))
    eye = sp.identity(k)
    zeros_kt = sp.csr_matrix((k, n - k + d.size))
    A_ub = sp.vstack([
        sp.hstack([program.A, sp.csr_matrix((program.shape[0], d.size + k))]),
        sp.hstack([rows_q, -pick_t, sp.csr_matrix((t_of.size, k))]),
        sp.hstack([eye, zeros_kt, -eye]),
        sp.hstack([-eye, zeros_kt, -eye]),
    ], format="csr")
    upper = np.concatenate([program.row_upper, -q0, np.zeros(2 * k)])
    lower = np.concatenate([program.row_lower, np.full(t_of.size + 2 * k, -np.inf)])
    eq = lower == upper
    cost = np.zeros(n + d.size + k)
    cost[k + d] = -1.0
    cost[n : n + d.size] = 1.0
    cost[n + d.size :] = lam * qmap.unknowns.weight
    vmax = program.upper[k]
    bounds = list(zip(program.lower, program.upper)) + [(-vmax, vmax)] * d.size + [(0, RMAX)] * k
    result = linprog(cost, A_ub=A_ub[~eq], b_ub=upper[~eq], A_eq=A_ub[eq], b_eq=upper[eq], bounds=bounds,
                     method="highs-ds")
    if result.status == 2:
        return None
    assert result.status == 0, result.message
    return -float(result.fun)  # the margin minus lambda ||R_S||_1


def fresh_intervals(constraints):
    """(k, 2) the interval ends by a fresh primal LP each (scipy), or None when infeasible."""
    program = constraints.program
    eq = program.row_lower == program.row_upper
    upper = ~eq & np.isfinite(program.row_upper)
    bounds = list(zip(program.lower, program.upper))
    ends = np.empty((constraints.qmap.k, 2))
    for j in range(constraints.qmap.k):
        for end, sign in ((0, 1.0), (1, -1.0)):
            cost = np.zeros(program.shape[1])
            cost[j] = sign
            result = linprog(cost, A_ub=program.A[upper], b_ub=program.row_upper[upper], A_eq=program.A[eq],
                             b_eq=program.row_lower[eq], bounds=bounds, method="highs-ds")
            if result.status == 2:
                return None
            assert result.status == 0, result.message
            ends[j, end] = sign * result.fun
    return ends


def assert_every_route_agrees(constraints, *, lam=0.0, margin=True, intervals=True):
    if margin:
        assert_margins_agree(constraints, lam=lam)
    if intervals:
        assert_intervals_agree(constraints)


def assert_margins_agree(constraints, *, lam):
    reference = epigraph_margin(constraints, lam=lam)
    for route in (dict(generate_rows=True), dict(generate_rows=False), dict(interior=True)):
        if reference is None:
            with pytest.raises(InfeasibleError):
                solve_margin_lp(constraints, lam=lam, **route)
            continue
        solution = solve_margin_lp(constraints, lam=lam, **route)
        objective = solution.margin - lam * constraints.qmap.unknowns.weight @ np.abs(solution.x[: constraints.qmap.k])
        # The interior point method's answer is as near as the gap it reports (0 for a vertex),
        # which is relative to max(|margin|, 1): absolute below 1 (hypothesis found a margin of
        # 0.475 whose answer was 1.5e-6 short, inside its gap of 2.3e-6 but not 2.3e-6 of 0.475).
        near = max(1e-7 * max(abs(reference), 1.0), solution.gap * max(abs(objective), 1.0))
        assert objective == pytest.approx(reference, rel=0, abs=near), route
        assert solution.interior == route.get("interior", False)
        assert constraints.violation(solution.x) <= 1e-6


def assert_intervals_agree(constraints):
    fresh = fresh_intervals(constraints)
    if fresh is None:
        for interior in (False, True):
            with pytest.raises(InfeasibleError):
                reward_intervals(constraints, interior=interior)
    else:
        ours, _ = reward_intervals(constraints)
        np.testing.assert_allclose(ours, fresh, rtol=1e-7, atol=1e-6)
        # The interior point route's ends are moved out by their gaps: outer bounds, and near.
        outer, _ = reward_intervals(constraints, interior=True)
        assert np.all(outer[:, 0] <= fresh[:, 0] + 1e-6) and np.all(outer[:, 1] >= fresh[:, 1] - 1e-6)
        np.testing.assert_allclose(outer, fresh, rtol=1e-4, atol=1e-3)


@pytest.mark.parametrize(("name", "episodes"), [("paper", 100), ("mud", 10), ("walled", 30), ("cliff-16", 100)])
def test_row_generation_slack_form_and_dual_intervals_match_the_full_lp(name, episodes):
    assert_every_route_agrees(constraints_for(world_named(name), episodes=episodes), intervals=name != "cliff-16")


def test_with_lambda_every_route_agrees():
    assert_every_route_agrees(constraints_for(BUILTIN_WORLDS["mud"], episodes=30), lam=2.0, intervals=False)


def test_tied_intervals_of_a_16x16_world_match_fresh_lps():
    assert_every_route_agrees(constraints_for(cliff_world(16, 16), episodes=100, tie=True), margin=False)


def test_tied_margin_of_a_16x16_world_without_presolve_matches_the_full_lp():
    tied = constraints_for(cliff_world(16, 16), episodes=100, tie=True)
    per_cell = constraints_for(cliff_world(16, 16), episodes=100)
    assert margin_options(margin_lp(tied)).get("presolve") == "off"
    assert "presolve" not in margin_options(margin_lp(per_cell))
    assert_margins_agree(tied, lam=0.0)


@st.composite
def small_problems(draw):
    rows, cols = draw(st.integers(2, 4)), draw(st.integers(2, 4))
    cells = draw(st.lists(st.sampled_from("...#CUG"), min_size=rows * cols, max_size=rows * cols))
    if not any(c in ".U" for c in cells):
        cells[0] = "."
    layout = "\n".join("".join(cells[r * cols : (r + 1) * cols]) for r in range(rows)) + "\n"
    world = World(layout=layout, levels=draw(st.integers(1, 3)), gamma=draw(st.sampled_from([0.5, 0.9, 0.95])),
                  rewards={s: r for s, r in {"C": -50.0, "U": -3.0, "G": 10.0}.items() if s in cells})
    mdp = build_mdp(world)
    acting = np.flatnonzero(mdp.nonterminal)
    shown = draw(st.lists(st.booleans(), min_size=acting.size, max_size=acting.size))
    if draw(st.booleans()):  # an optimal expert, partly demonstrated: feasible
        actions = optimal_policy(mdp).argmax(axis=1)[acting]
    else:  # any actions: often infeasible
        actions = np.array(draw(st.lists(st.integers(0, mdp.n_actions - 1), min_size=acting.size, max_size=acting.size)))
    policy = np.full(mdp.n_states, -1)
    policy[acting[np.array(shown, dtype=bool)]] = actions[np.array(shown, dtype=bool)]
    unknowns = build_unknowns(mdp, reward_cells=draw(st.sampled_from(["special", "all"])), tie=draw(st.booleans()))
    return lp_constraints(build_qmap(mdp, unknowns), policy, rmax=RMAX)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_problems(), st.sampled_from([0.0, 0.5]))
def test_random_small_worlds_every_route_agrees(constraints, lam):
    assert_every_route_agrees(constraints, lam=lam)


def test_infeasible_demonstrations_are_infeasible_on_every_route():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    policy = np.full(mdp.n_states, -1)
    # Walking into the top-left corner's wall at the highest level: costly and pointless.
    policy[mdp.state_of[(0, 0)]] = 13
    constraints = lp_constraints(build_qmap(mdp, build_unknowns(mdp)), policy, rmax=RMAX)
    assert epigraph_margin(constraints) is None
    assert_every_route_agrees(constraints)


def test_progress_hears_of_rounds_and_interval_lps():
    mdp = build_mdp(BUILTIN_WORLDS["mud"])
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=20, seed=0))
    heard = []
    result = fit(demos, method="lp", intervals=True, progress=lambda stage, done, total: heard.append((stage, done, total)))
    rounds = [done for stage, done, _ in heard if stage == "rounds"]
    lps = [(done, total) for stage, done, total in heard if stage == "intervals"]
    assert rounds == list(range(1, len(rounds) + 1)) and rounds
    assert lps == [(i, 2 * result.unknowns.k) for i in range(1, 2 * result.unknowns.k + 1)]


def test_every_per_cell_interval_lp_of_a_32x32_world_is_answered():
    # Regression: on the landed main 4 of these 62 LPs ended "unknown"; they now take about 2 s.
    mdp = build_mdp(cliff_world(32, 32))
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=100, seed=0))
    result = fit(demos, method="lp", intervals=True)
    truth = result.unknowns.true_theta(mdp)
    low, high = result.intervals.T
    assert result.intervals.shape == (31, 2) and np.all(np.isfinite(result.intervals))
    assert np.all(low <= truth + 1e-6) and np.all(truth <= high + 1e-6)
    assert np.all(low <= result.theta + 1e-6) and np.all(result.theta <= high + 1e-6)
    assert low[:-1] == pytest.approx(np.full(30, -RMAX))  # nothing the expert did bounds a cliff cell from below


def test_every_tied_interval_lp_of_a_32x32_world_is_answered():
    # Regression: the interior point method gave an infeasible answer (by 39) to 1 of these 4 LPs.
    mdp = build_mdp(cliff_world(32, 32))
    demos = demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=100, seed=0))
    tied = fit(demos, method="lp", tie=True, intervals=True)
    truth = tied.unknowns.true_theta(mdp)
    low, high = tied.intervals.T
    assert tied.labels == ("C", "G") and np.all(np.isfinite(tied.intervals))
    assert np.all(low <= truth + 1e-6) and np.all(truth <= high + 1e-6)
    assert np.all(low <= tied.theta + 1e-6) and np.all(tied.theta <= high + 1e-6)
    assert high[0] < low[1]  # carefulness separates the cliff from the goal
