"""bench_battery's seam: its fits are `careful fit`'s flags, read by careful fit's own parser, so that another
kind of interval (a new flag) is measured by the same bench; and its counting is careful check's."""

import numpy as np
import pytest

from bench.bench_battery import Run, coverage_rows, fit_options
from irl_core.coverage.check import DatasetFit


def test_fit_args_are_careful_fits_flags_with_intervals_always_on():
    options = fit_options("--tie --resamples 50 --rmax 2000")
    assert options.tie and options.intervals and options.resamples == 50 and options.rmax == 2000
    assert not fit_options("--intervals").tie


@pytest.mark.parametrize("flags", ["--widen nothing", "--resamples many", "--confidence 2"])
def test_a_flag_careful_fit_refuses_stops_the_bench_before_any_fit(flags):
    with pytest.raises(SystemExit) as stopped:
        fit_options(flags)
    assert stopped.value.code == 2


def test_a_row_counts_the_seeds_whose_interval_held_the_truth_every_cell_at_once():
    truth = np.array([-30.0, -30.0, 100.0])

    def run(seed, low, high):
        fitted = DatasetFit(np.array([-30.0, -30.0, 90.0]), np.column_stack([low, high]))
        return Run("loose", "mud", "--intervals", seed, ("U", "U", "G"), truth, fitted, "maxent naive", 1.0)

    done = [run(0, [-40, -40, 80], [-20, -20, 120]),   # all held
            run(1, [-40, -25, 80], [-20, -20, 95]),    # one U cell and G missed
            run(2, [-40, -40, 80], [-20, -20, 101])]   # all held
    rows = {row.symbol: (row.covered, seeds) for _, _, _, row, seeds in coverage_rows(done, {"--intervals": 1000.0})}
    assert rows == {"U": (2, 3), "G": (2, 3)}
