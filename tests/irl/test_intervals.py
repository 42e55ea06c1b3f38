"""--intervals: the range of every unknown over the lp constraints, and what carefulness buys."""

import numpy as np
import pytest
from scipy.optimize import linprog

from irl_core.irl import fit
from irl_core.irl.intervals.identified import reward_intervals
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.players.experts import boltzmann_policy, optimal_policy, rollouts
from irl_core.recordings.demonstrations import Demonstrations
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

TOLERANCE = 1e-6


def optimal_demonstrations(name, episodes, seed):
    mdp = build_mdp(BUILTIN_WORLDS[name])
    result = rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    return Demonstrations(mdp=mdp, counts=counts, files=1, episodes=episodes, steps=int(counts.sum()))


def symbol_intervals(result, symbol):
    return result.intervals[np.array(result.unknowns.symbols) == symbol]


def true_values(result):
    """The world's own rewards in the fit's unit (relative to G where nothing fixes the units)."""
    return result.true_theta()


@pytest.mark.parametrize("name", ["paper", "mud"])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_ten_episodes_stay_feasible_and_every_interval_holds_the_truth(name, seed):
    demos = optimal_demonstrations(name, 10, seed)
    assert (demos.demonstrated & demos.mdp.nonterminal).sum() < demos.mdp.nonterminal.sum()
    result = fit(demos, method="lp", intervals=True)
    truth = true_values(result)
    low, high = result.intervals.T
    assert np.all(low <= truth + TOLERANCE * 1000) and np.all(truth <= high + TOLERANCE * 1000)
    assert np.all(low <= result.theta + 1e-6) and np.all(result.theta <= high + 1e-6)


@pytest.fixture(scope="module")
def mud():
    return fit(optimal_demonstrations("mud", 100, 0), method="lp", intervals=True)


@pytest.fixture(scope="module")
def mud_simple():
    return fit(optimal_demonstrations("mud-simple", 100, 0), method="lp", intervals=True)


def test_with_carefulness_the_cliff_lies_below_the_mud(mud):
    cliff, mud_cells = symbol_intervals(mud, "C"), symbol_intervals(mud, "U")
    assert cliff[:, 1].max() < mud_cells[:, 0].min()
    for symbol, true in (("C", -1000.0), ("U", -30.0)):
        bounds = symbol_intervals(mud, symbol)
        assert np.all(bounds[:, 0] <= true + TOLERANCE) and np.all(true <= bounds[:, 1] + TOLERANCE)


def test_without_carefulness_cliff_and_mud_overlap(mud_simple):
    cliff, mud_cells = symbol_intervals(mud_simple, "C"), symbol_intervals(mud_simple, "U")
    assert cliff[:, 1].max() >= mud_cells[:, 0].min()
    truth = true_values(mud_simple)
    assert np.all(mud_simple.intervals[:, 0] <= truth + TOLERANCE)
    assert np.all(truth <= mud_simple.intervals[:, 1] + TOLERANCE)


def test_reused_model_gives_the_same_ends_as_fresh_lps():
    demos = optimal_demonstrations("mud", 10, 1)
    constraints = lp_constraints(build_qmap(demos.mdp, build_unknowns(demos.mdp)), demos.most_frequent, rmax=1000.0)
    intervals, _ = reward_intervals(constraints)
    program = constraints.program
    eq = program.row_lower == program.row_upper
    upper = ~eq & np.isfinite(program.row_upper)
    bounds = list(zip(program.lower, program.upper))
    for j in range(constraints.qmap.k):
        for end, sign in ((0, 1.0), (1, -1.0)):
            cost = np.zeros(constraints.qmap.n)
            cost[j] = sign
            fresh = linprog(cost, A_ub=program.A[upper], b_ub=program.row_upper[upper], A_eq=program.A[eq],
                            b_eq=program.row_lower[eq], bounds=bounds, method="highs")
            assert intervals[j, end] == pytest.approx(sign * fresh.fun, abs=1e-6)


def test_tied_intervals_cover_every_cell_of_the_symbol(mud):
    tied = fit(optimal_demonstrations("mud", 100, 0), method="lp", tie=True, intervals=True)
    assert tied.labels == ("U", "C", "G")
    grid = tied.interval_grid
    np.testing.assert_allclose(grid[3, 1:5], np.repeat(tied.intervals[1][None, :], 4, axis=0))
    # One value per symbol can only narrow what per-cell values allow.
    assert tied.intervals[1, 1] <= symbol_intervals(mud, "C")[:, 1].max() + TOLERANCE


def test_noisy_demonstrations_fit_by_loss_say_why_there_are_no_intervals():
    mdp = build_mdp(BUILTIN_WORLDS["paper"])
    result = rollouts(mdp, boltzmann_policy(mdp, beta=1.0), episodes=10, seed=0)
    counts = np.zeros((mdp.n_states, mdp.n_actions))
    np.add.at(counts, (result.state, result.action), 1.0)
    demos = Demonstrations(mdp=mdp, counts=counts, files=1, episodes=10, steps=int(counts.sum()))
    fitted = fit(demos, method="loss", intervals=True)
    assert fitted.intervals is None
    assert any(str(note).startswith("intervals not computed") for note in fitted.notes)
    assert np.isnan(fitted.interval_grid).all()
