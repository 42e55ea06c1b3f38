"""The margin LP past `lp.INTERIOR_ROWS`, or after the dual simplex failed: solved by the interior
point method, which says how near its answer is (the gap to its dual bound), and what the fit
then says, with intervals that hold the identified set.

That the interior route reaches the whole LP's optimum, and outer bounds of its intervals, on
the worlds of the other routes is in `test_lp_paths.py` (`assert_margins_agree`,
`assert_intervals_agree`).
"""

import numpy as np
import pytest

from bench.fit_stage import demonstrations_for
from bench.worlds import cliff_world
from irl_core.irl import fit
from irl_core.irl.lp import solve as lp
from irl_core.irl.intervals.identified import reward_intervals
from irl_core.irl.lp.highs import INTERIOR, HighsModel
from irl_core.irl.lp.margin import lp_constraints
from irl_core.irl.qmap import build_qmap, build_unknowns
from irl_core.worlds.mdp import build_mdp

RMAX = 1000.0


@pytest.fixture(scope="module")
def cliff16():
    mdp = build_mdp(cliff_world(16, 16))
    demos = demonstrations_for(mdp, episodes=100, seed=0)
    qmap = build_qmap(mdp, build_unknowns(mdp, reward_cells="special"))
    return demos, lp_constraints(qmap, demos.most_frequent, rmax=RMAX)


def test_a_stopped_interior_answer_is_as_near_as_the_gap_it_reports(cliff16):
    """IPX stopped early (a loose optimality tolerance) leaves a point short of the optimum; the
    gap reported must cover how far short it is, as the fit's note says it does."""
    _, constraints = cliff16
    whole = lp.margin_lp(constraints).full()
    optimum = HighsModel(whole).solve()[1].objective
    inaccurate = 0
    for tolerance in (1e-2, 1e-3, 1e-4, 1e-6):
        _, report = HighsModel(whole, options={**INTERIOR, "ipm_optimality_tolerance": tolerance}).solve()
        assert report.kind == "answer" and report.solver == "ipx"
        short = abs(report.objective - optimum) / max(abs(report.objective), 1.0)
        assert short <= report.gap + 1e-9, tolerance
        inaccurate += report.gap > 1e-4
    assert inaccurate >= 1  # the check above saw answers well short of the optimum


def test_the_size_switch_is_by_the_first_rounds_rows(cliff16, monkeypatch):
    _, constraints = cliff16
    rows = lp.first_round_rows(lp.margin_lp(constraints))
    assert rows == 1318  # the base rows and the seed of the 16x16 world
    assert not lp.solve_margin_lp(constraints).interior
    monkeypatch.setattr(lp, "INTERIOR_ROWS", rows - 1)
    solution = lp.solve_margin_lp(constraints)
    assert solution.interior and solution.first_rows == rows
    assert solution.margin == pytest.approx(lp.solve_margin_lp(constraints, interior=False).margin, rel=1e-7)


def test_a_tied_fit_switches_at_its_own_rows(cliff16, monkeypatch):
    """Tied fits are solved by the simplex from HiGHS's own start, which gives out sooner
    (`lp.TIED_INTERIOR_ROWS`); a fit per cell keeps `lp.INTERIOR_ROWS`."""
    demos, constraints = cliff16
    qmap = build_qmap(constraints.qmap.mdp, build_unknowns(constraints.qmap.mdp, reward_cells="special", tie=True))
    tied = lp_constraints(qmap, demos.most_frequent, rmax=RMAX)
    assert lp.interior_rows(lp.margin_lp(tied)) == lp.TIED_INTERIOR_ROWS < lp.INTERIOR_ROWS
    assert lp.interior_rows(lp.margin_lp(constraints)) == lp.INTERIOR_ROWS
    rows = lp.first_round_rows(lp.margin_lp(tied))
    monkeypatch.setattr(lp, "TIED_INTERIOR_ROWS", rows - 1)
    solution = lp.solve_margin_lp(tied)
    assert solution.interior and solution.interior_rows == rows - 1
    assert not lp.solve_margin_lp(constraints).interior
    notes = " ".join(map(str, fit(demos, method="lp", reward_cells="special", tie=True, rmax=RMAX).notes))
    assert f"(the simplex is used up to {rows - 1:,})" in notes


def test_a_fit_past_the_switch_says_how_it_was_solved_and_its_intervals_hold_the_identified_set(cliff16, monkeypatch):
    demos, constraints = cliff16
    simplex_intervals, _ = reward_intervals(constraints)
    monkeypatch.setattr(lp, "INTERIOR_ROWS", 1000)
    result = fit(demos, method="lp", reward_cells="special", intervals=True, rmax=RMAX)
    notes = " ".join(map(str, result.notes))
    assert "lp solved by the interior point method, as this world's LP has 1,318 rows in its first round" in notes
    assert "(the simplex is used up to 1,000)" in notes
    assert "intervals by the interior point method, as the fit: each of the 30 interval LPs" in notes
    assert result.status in ("optimal", "optimal_inaccurate")
    assert result.interval_kind == "identified"
    # Outer bounds of the set the simplex finds exactly, and close to it: measured at most 2.3e-5
    # relative wider (the goal's lower end 97.9318 against 97.9341).
    assert np.all(result.intervals[:, 0] <= simplex_intervals[:, 0] + 1e-6)
    assert np.all(result.intervals[:, 1] >= simplex_intervals[:, 1] - 1e-6)
    np.testing.assert_allclose(result.intervals, simplex_intervals, rtol=1e-4, atol=1e-3)
    # Still the lp's answer: the same reward as the simplex where the optimum is a single point
    # is not promised (an interior point of the optimal face), but the cliff stays bad.
    simplex = fit(demos, method="lp", reward_cells="special", rmax=RMAX)
    assert np.sign(result.theta).tolist() == np.sign(simplex.theta).tolist()


def test_a_failed_round_of_the_simplex_is_solved_again_by_the_interior_point_method(cliff16, monkeypatch):
    """Below the switch the dual simplex can still fail (an 84x84 world's first round: "solve
    error" after 70 s). The fit then goes on by the interior point method, not by the cascade of
    retries, and says why. The failure here is HiGHS's own: an iteration limit of 0."""
    demos, constraints = cliff16
    simplex = lp.solve_margin_lp(constraints)
    monkeypatch.setattr(lp, "MARGIN_OPTIONS", {**lp.MARGIN_OPTIONS, "simplex_iteration_limit": 0})
    seen = []
    solution = lp.solve_margin_lp(constraints, progress=lambda stage, done, total: seen.append(done))
    assert solution.interior and solution.simplex_failure == "iteration limit in round 1"
    assert abs(solution.margin - simplex.margin) <= solution.gap * max(simplex.margin, 1.0) + 1e-7
    # The failed round is one of the rounds, and the progress counts on from it.
    assert seen == list(range(2, solution.rounds + 1)) and solution.rounds >= 2
    notes = " ".join(map(str, fit(demos, method="lp", reward_cells="special", rmax=RMAX).notes))
    assert ("lp solved by the interior point method, as the dual simplex failed (iteration limit in round 1); "
            "the gap between its margin") in notes
