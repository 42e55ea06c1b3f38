"""One test of "at the ±rmax bound" (`irl_core.irl.at_bound`), loose enough for a solver's last
digits: a bootstrap end the bound set reads "no lower bound", not "between -1000 and ...".

The near-bound end is real: the loss fit of a Boltzmann expert in mud (beta 1, 30 episodes,
seed 5), its intervals from 100 resamples with seed 5, puts C (3, 3)'s lower end at -999.99948.
"""

import json

import numpy as np
import pytest

from careful_tui.cli import main
from careful_tui.render.intervals import interval_reading, interval_span
from irl_core.irl import at_bound

NEAR_END = -999.99948238  # that fit's C (3, 3) lower end, rmax 1000
DATA_SET = -999.94510243  # that loss fit's C (3, 2): set by the data (--rmax 2000 moves it to -987), not the bound


def test_an_end_a_solver_left_a_hair_inside_the_bound_is_no_bound():
    assert interval_reading(NEAR_END, -252.4, 1000.0) == "at most -252; no lower bound"
    assert interval_span(NEAR_END, -252.4, 1000.0) == "≤ -252"
    assert interval_reading(83.3, 999.9999, 1000.0) == "at least 83.3; no upper bound"


def test_a_value_the_data_set_near_the_bound_is_still_a_bound():
    assert not at_bound(DATA_SET, 1000.0)
    assert interval_reading(DATA_SET, -252.4, 1000.0) == "between -1000 and -252"


def test_at_bound_is_elementwise_and_symmetric():
    values = np.array([-1000.0, NEAR_END, DATA_SET, 0.0, 999.995, 1000.0])
    assert at_bound(values, 1000.0).tolist() == [True, True, False, False, True, True]
    assert at_bound(-5e5 * (1 - 1e-7), 5e5) and not at_bound(-4.9e5, 5e5)


def test_the_printout_reads_a_real_near_bound_end_as_no_lower_bound(capsys, tmp_path):
    recording, result = tmp_path / "mud.jsonl", tmp_path / "fit.json"
    assert main(["simulate", "--world", "mud", "--policy", "boltzmann", "--beta", "1", "--episodes", "30",
                 "--seed", "5", "--out", str(recording)]) == 0
    assert main(["fit", str(recording), "--method", "loss", "--intervals", "--resamples", "100", "--seed", "5",
                 "--no-view", "--json", str(result)]) == 0
    out = capsys.readouterr().out
    low = json.loads(result.read_text())["interval"][3][3][0]
    assert low == pytest.approx(NEAR_END, abs=1e-3) and low > -1000  # the case is still the near miss
    row = next(line for line in out.splitlines() if line.startswith("│ C (3, 3)"))
    assert "at most -252; no lower bound" in row
    assert "between -1000" not in out
