"""Calibrated intervals: the scales careful check learns (checked against a brute-force search over a grid of
scales, widening each refit's interval and counting the datasets it holds), the widening itself, the
calibration file (read back whole; a bad one is one line naming file, line and field) and its refusal on
another world or other fit options."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from irl_core.coverage.calibrate import learn_scales, level_scale, needed_scales
from irl_core.errors import CalibrationError
from irl_core.irl.intervals.calibrated import Calibration, options_text, read_calibration, widen, world_digest
from irl_core.irl.options import FitOptions
from irl_core.worlds.world import BUILTIN_WORLDS

RMAX = 1000.0


def calibration(scales, *, options=None, world=BUILTIN_WORLDS["mud"]):
    return Calibration(scales=tuple(scales.items()), confidence=0.95, options=options_text(options or FitOptions()),
                       world=world.name, world_digest=world_digest(world), players=("naive", "loose"), datasets=20,
                       episodes=30, seed=0)


def reaches(sources, symbols, symbol, confidence, w):
    """Whether widening by `w` (`widen`, as a fit widens) holds the truth in at least `confidence` of every
    source's datasets, counted as the tally counts (every cell of the symbol held)."""
    cells = [j for j, s in enumerate(symbols) if s == symbol]
    for points, intervals, truth in sources:
        held = 0
        for p, bounds in zip(points, intervals):
            wide = widen(p, bounds, symbols, calibration({symbol: w}), rmax=RMAX)
            held += all(wide[j, 0] - 1e-6 * RMAX <= truth[j] <= wide[j, 1] + 1e-6 * RMAX for j in cells)
        if held < confidence * len(points) - 1e-9:
            return False
    return True


def grid_scale(sources, symbols, symbol, confidence, grid):
    """The smallest scale of `grid` that `reaches` the level, or None: found by bisection, since widening more
    never holds fewer datasets."""
    if not reaches(sources, symbols, symbol, confidence, grid[-1]):
        return None
    if reaches(sources, symbols, symbol, confidence, grid[0]):
        return grid[0]
    low, high = 0, len(grid) - 1  # grid[high] reaches the level, grid[low] does not
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (low, middle) if reaches(sources, symbols, symbol, confidence, grid[middle]) else (middle, high)
    return grid[high]


@st.composite
def refit_tables(draw):
    """Two players' refits of 8 to 20 datasets each, of two cells of symbol A and one of B: points, intervals
    around them (each side 0.5 to 20 wide) and truths somewhere near."""
    symbols = ("A", "A", "B")
    sources = []
    for _ in range(2):
        n = draw(st.integers(8, 20))
        points = np.array(draw(st.lists(st.lists(st.floats(-50, 50), min_size=3, max_size=3), min_size=n, max_size=n)))
        below = np.array(draw(st.lists(st.lists(st.floats(0.5, 20), min_size=3, max_size=3), min_size=n, max_size=n)))
        above = np.array(draw(st.lists(st.lists(st.floats(0.5, 20), min_size=3, max_size=3), min_size=n, max_size=n)))
        truth = np.array(draw(st.lists(st.floats(-80, 80), min_size=3, max_size=3)))
        sources.append((points, np.stack([points - below, points + above], axis=2), truth))
    return symbols, sources


@settings(max_examples=25, deadline=None, derandomize=True)
@given(table=refit_tables(), confidence=st.sampled_from([0.8, 0.9, 0.95]))
def test_the_learned_scale_is_the_smallest_on_a_fine_grid_that_reaches_the_level(table, confidence):
    symbols, sources = table
    learned = learn_scales(sources, symbols, confidence=confidence, tolerance=1e-6 * RMAX)
    step = 0.01
    grid = np.arange(1.0, 60.0, step)
    for symbol in ("A", "B"):
        found = grid_scale(sources, symbols, symbol, confidence, grid)
        if found is None:  # beyond the grid: the learned one is too
            assert learned[symbol] is None or learned[symbol] > grid[-1] - step
            continue
        assert learned[symbol] is not None
        assert found - step - 1e-9 <= learned[symbol] <= found + 1e-9
        if learned[symbol] > 1.0:  # and it does reach the level (the grid's scale just below it does not)
            assert reaches(sources, symbols, symbol, confidence, learned[symbol] + 1e-9)


def test_a_hand_made_table_its_scales_by_hand():
    # 20 datasets, point 0, interval [-1, 2]; truths: 17 inside, then 3 (needs 1.5), -4 (needs 4), 10 (needs 5).
    points = np.zeros((20, 1))
    intervals = np.tile([[-1.0, 2.0]], (20, 1, 1))
    truths = [0.5] * 17 + [3.0, -4.0, 10.0]
    needs = np.concatenate([needed_scales(points[:1], intervals[:1], np.array([t]), [0], tolerance=0.0)
                            for t in truths])
    assert needs.tolist() == [1.0] * 17 + [1.5, 4.0, 5.0]
    assert level_scale(needs, 0.85) == 1.0  # 17 of 20 already held
    assert level_scale(needs, 0.9) == 1.5  # 18 of 20
    assert level_scale(needs, 0.95) == 4.0  # 19 of 20
    assert level_scale(needs, 0.99) == 5.0  # all 20


def test_a_truth_beside_a_side_of_no_width_has_no_scale_and_gets_the_whole_range():
    points = np.array([[5.0], [5.0]])
    intervals = np.array([[[5.0, 9.0]], [[5.0, 9.0]]])  # the point is the interval's lower end
    assert learn_scales([(points, intervals, np.array([0.0]))], ("G",), confidence=0.95, tolerance=0.0) == {"G": None}
    wide = widen(np.array([5.0]), intervals[0], ("G",), calibration({"G": None}), rmax=RMAX)
    assert wide.tolist() == [[-RMAX, RMAX]]


def test_widening_keeps_the_point_inside_clips_to_the_bound_and_keeps_one_sided_intervals_one_sided():
    theta = np.array([-20.0, -1000.0, 80.0])
    bounds = np.array([[-50.0, -10.0], [-1000.0, -600.0], [30.0, 990.0]])
    wide = widen(theta, bounds, ("U", "C", "G"), calibration({"U": 2.0, "C": 1.5, "G": 3.0}), rmax=RMAX)
    assert wide.tolist() == [[-80.0, 0.0], [-1000.0, -400.0], [-70.0, 1000.0]]
    assert (wide[:, 0] <= theta).all() and (theta <= wide[:, 1]).all()
    assert (wide[:, 0] <= bounds[:, 0]).all() and (bounds[:, 1] <= wide[:, 1]).all()
    assert widen(theta, bounds, ("U", "C", "G"), calibration({"X": 9.0}), rmax=RMAX).tolist() == bounds.tolist()


def test_a_calibration_file_reads_back_as_it_was_written(tmp_path):
    written = calibration({"U": 1.25, "C": None, "G": 3.5}, options=FitOptions(tie=True))
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps(written.to_json(), indent=2))
    assert read_calibration(path) == written


@pytest.mark.parametrize(("change", "field", "line"), [
    (lambda d: d["scales"].update(G=0.5), "scales", 3),
    (lambda d: d["scales"].update(G="wide"), "scales", 3),
    (lambda d: d.update(confidence=1.5), "confidence", None),
    (lambda d: d.update(format="something else"), "format", 2),
    (lambda d: d.pop("world"), "world", 1),
    (lambda d: d.update(datasets=-1), "datasets", None),
])
def test_a_bad_calibration_file_is_one_line_naming_file_line_and_field(tmp_path, change, field, line):
    data = calibration({"U": 1.25, "G": 3.5}).to_json()
    change(data)
    text = json.dumps(data, indent=2)
    path = tmp_path / "calibration.json"
    path.write_text(text)
    with pytest.raises(CalibrationError) as error:
        read_calibration(path)
    message = str(error.value)
    expected = line or next(i for i, row in enumerate(text.splitlines(), 1) if f'"{field}":' in row)
    assert message.startswith(f"{path}:{expected}: {field}: ") and "\n" not in message


def test_a_file_that_is_not_json_names_its_line(tmp_path):
    path = tmp_path / "calibration.json"
    path.write_text('{\n  "format": "careful calibration 1",\n  "scales": {oops}\n}\n')
    with pytest.raises(CalibrationError, match=rf"^{path}:3: not JSON"):
        read_calibration(path)


def test_another_world_or_other_fit_options_are_named():
    learned = calibration({"G": 2.0}, options=FitOptions(tie=True))
    assert learned.mismatch(FitOptions(tie=True, seed=7, intervals=True), BUILTIN_WORLDS["mud"]) is None
    assert learned.mismatch(FitOptions(tie=True), BUILTIN_WORLDS["paper"]).startswith("world: ")
    edited = BUILTIN_WORLDS["mud"].model_copy(update={"rewards": {"C": -500.0, "G": 100.0, "U": -30.0}})
    assert "its file has changed" in learned.mismatch(FitOptions(tie=True), edited)
    assert learned.mismatch(FitOptions(), BUILTIN_WORLDS["mud"]).startswith("options.tie: learned with true")
    assert learned.mismatch(FitOptions(tie=True, method="loss"), BUILTIN_WORLDS["mud"]).startswith("options.method")
    assert learned.mismatch(FitOptions(tie=True, resamples=50), BUILTIN_WORLDS["mud"]).startswith("options.resamples")
