"""`careful check`'s arithmetic against an independent count: coverage per symbol (per cell: every cell of the
symbol), the medians, and the verdict's binomial band computed from the binomial's own terms; the rivals each
world takes, the battery's among them."""

from math import comb

import numpy as np
import pytest

from irl_core.coverage.check import DatasetFit, coverage_band, tally, verdict
from irl_core.coverage.rivals import default_rivals, parse_rivals, rival_choices, rivals_for
from irl_core.coverage.simulate import dataset_rng, rival_chooser, simulate_dataset
from irl_core.errors import UsageError
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import load_world


def random_fits(rng, k, n):
    fits = []
    for _ in range(n):
        centre = rng.normal(0, 2, k)
        half = rng.uniform(0.5, 3, k)
        fits.append(DatasetFit(centre + rng.normal(0, 0.5, k), np.column_stack([centre - half, centre + half])))
    return fits


def test_tied_coverage_is_the_count_of_intervals_holding_the_truth():
    rng = np.random.default_rng(4)
    symbols, truth = ("U", "C", "G"), np.array([0.5, -1.0, 2.0])
    fits = random_fits(rng, 3, 40) + [DatasetFit(None, None, "the fit failed"), DatasetFit(np.zeros(3), None, "x")]
    rows = tally("naive", rival=False, symbols=symbols, truth=truth, fits=fits, rmax=1000.0)
    for j, row in enumerate(rows):
        held, widths, errors = 0, [], []
        for f in fits[:40]:
            low, high = f.intervals[j]
            held += int(low <= truth[j] <= high)
            widths.append(high - low)
            errors.append(f.theta[j] - truth[j])
        assert (row.symbol, row.datasets, row.covered) == (symbols[j], 40, held)
        assert row.coverage == held / 40
        assert row.median_width == pytest.approx(sorted(widths)[19] / 2 + sorted(widths)[20] / 2)
        assert row.median_error == pytest.approx(np.median(errors))


def test_a_per_cell_symbol_is_covered_only_when_every_cell_holds_its_truth():
    symbols, truth = ("C", "C", "G"), np.array([-10.0, -10.0, 5.0])
    both = DatasetFit(np.array([-9, -11, 5.0]), np.array([[-12, -8], [-12, -9], [4, 6]]))
    one = DatasetFit(np.array([-9, -7, 5.0]), np.array([[-12, -8], [-9, -6], [4, 6]]))
    rows = tally("loose", rival=True, symbols=symbols, truth=truth, fits=[both, one], rmax=1000.0)
    assert [(r.symbol, r.datasets, r.covered) for r in rows] == [("C", 2, 1), ("G", 2, 2)]
    assert rows[0].cells()[:6] == ["loose", "true", "C", "2", "1", "0.5"]


def test_a_truth_at_the_bound_is_held_by_an_interval_ending_there():
    fit = DatasetFit(np.array([-1000.0]), np.array([[-999.9995, -140.0]]))
    assert tally("x", rival=False, symbols=("C",), truth=np.array([-1000.0]), fits=[fit], rmax=1000.0)[0].covered == 1


def binomial_band(n, p):
    """The central 95%: the smallest k with P(X <= k) >= 0.025 and the smallest with P(X <= k) >= 0.975."""
    cdf = np.cumsum([comb(n, k) * p**k * (1 - p) ** (n - k) for k in range(n + 1)])
    return int(np.argmax(cdf >= 0.025 - 1e-12)), int(np.argmax(cdf >= 0.975 - 1e-12))


@pytest.mark.parametrize(("n", "p"), [(50, 0.95), (20, 0.95), (200, 0.9), (7, 0.8)])
def test_the_band_is_the_binomials_central_95_percent(n, p):
    assert coverage_band(n, p) == binomial_band(n, p)


def test_the_verdict_names_the_symbols_below_the_band():
    from irl_core.coverage.check import CoverageRow

    low, high = coverage_band(50, 0.95)
    assert (low, high) == (44, 50)

    def row(symbol, covered):
        return CoverageRow("naive", False, symbol, 50, covered, 1.0, 0.0)

    assert verdict([row("U", low), row("G", 50)], 0.95) == "nominal"
    assert verdict([row("U", low - 1), row("C", 50), row("G", 10)], 0.95) == "under-covering: U, G"
    low, high = coverage_band(200, 0.5)
    assert verdict([CoverageRow("x", True, "G", 200, high + 1, 1.0, 0.0)], 0.5) == "over-covering: G"


def test_the_rivals_are_the_worlds_own_players():
    mud, time_world = load_world("mud"), load_world("mud-time")
    assert "timing" not in rival_choices(mud) and default_rivals(mud) == ("loose", "timed", "hasty")
    assert time_world.care == "time" and "timed" not in rival_choices(time_world)
    with pytest.raises(UsageError, match="on 'mud' the players are loose, timed, hasty, inverted, reckless"):
        rivals_for(("steady",), mud)


@pytest.mark.parametrize("kind", ["streaky", "growing", "learning"])
def test_the_battery_players_are_rivals_that_play_a_dataset_of_the_recordings_size(kind):
    mdp = build_mdp(load_world("mud"))
    assert rivals_for(parse_rivals(f"loose,{kind}"), mdp.world) == ("loose", kind)
    starts = np.full(30, mdp.state_of[mdp.world.start_cells[0]])
    demos = simulate_dataset(mdp, rival_chooser(mdp, kind), starts, dataset_rng(0, 1, 0), recorded_mdp=mdp)
    again = simulate_dataset(mdp, rival_chooser(mdp, kind), starts, dataset_rng(0, 1, 0), recorded_mdp=mdp)
    assert demos.episodes == 30 and np.array_equal(demos.counts, again.counts)
