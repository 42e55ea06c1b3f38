"""`careful fit REACH.jsonl --figure`: the field with the recorded reaches and both optima, the durations by distance
to the penalty, the intervals; a symbol bounded on one side shown as its bound, never as a point."""

import numpy as np
import pytest

from careful_tui.cli import main
from careful_tui.render.figures.reach_figure import interval_rows, optima, penalty_distance, reach_fit_figure
from careful_tui.render.reach_fit import shown_points
from irl_core.reach.fit import fit_reaches
from irl_core.reach.gain import best_choice, choice_grid
from irl_core.recordings.reach_reader import read_reaches


def simulated(folder, world, policy, trials, seed):
    path = folder / f"{world}-{policy}-{seed}.jsonl"
    assert main(["simulate", "--world", world, "--policy", policy, "--episodes", str(trials), "--seed", str(seed),
                 "--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def maximiser(tmp_path_factory):
    reaches = read_reaches([simulated(tmp_path_factory.mktemp("max"), "reach", "optimal", 30, 0)])[0]
    return fit_reaches(reaches), reaches


def axes_by_label(figure):
    return {ax.get_label(): ax for ax in figure.get_axes()}


def test_a_one_sided_penalty_is_its_bound_in_the_field_and_has_no_point_among_the_intervals(maximiser):
    fit, _ = maximiser
    assert fit.interval["C"][0] == -1e5  # the maximiser's choice bounds the penalty above only
    assert shown_points(fit, "C") == f"≤{fit.interval['C'][1]:.3g}"
    rows = {row.symbol: row for row in interval_rows(fit)}
    assert np.isnan(rows["C"].estimate) and rows["G"].estimate == fit.reward["G"]
    figure = reach_fit_figure(fit, maximiser[1])
    texts = [text.get_text() for text in axes_by_label(figure)["field"].texts]
    assert f"C {shown_points(fit, 'C')}" in texts and not any(str(round(fit.reward["C"])) in t for t in texts)


def test_the_field_and_the_durations_show_the_reaches_and_both_optima(maximiser):
    fit, reaches = maximiser
    best = optima(fit)
    world = fit.world
    true_aim, true_ms = best_choice(choice_grid(world), list(world.points.values()))
    assert best.true[0].tolist() == true_aim.tolist() and best.true[1] == true_ms
    axes = axes_by_label(reach_fit_figure(fit, reaches))
    endpoints, aims = (collection.get_offsets() for collection in axes["field"].collections[-2:])
    np.testing.assert_array_equal(endpoints, reaches.endpoints)
    np.testing.assert_array_equal(aims, reaches.aims)
    diamonds = [line.get_xydata()[0].tolist() for line in axes["field"].lines]
    assert best.fitted[0].tolist() in diamonds and true_aim.tolist() in diamonds
    (durations,) = axes["durations"].collections
    np.testing.assert_allclose(durations.get_offsets(),
                               np.c_[penalty_distance(world, reaches.aims), reaches.durations])
    assert "intervals" in axes


def test_careful_fit_writes_the_figure_and_never_over_a_recording(tmp_path, capsys):
    recording = simulated(tmp_path, "reach-mild", "hand", 60, 1)
    out = tmp_path / "fit.svg"
    assert main(["fit", str(recording), "--no-view", "--figure", str(out)]) == 0
    assert out.read_text().lstrip().startswith("<?xml") and "reach fit of reach-mild" in capsys.readouterr().out
    before = recording.read_bytes()
    assert main(["fit", str(recording), "--no-view", "--figure", str(recording.with_suffix(".png")),
                 "--json", str(recording)]) == 2
    assert recording.read_bytes() == before


def test_points_that_may_be_any_value_show_as_any_with_no_best_aim_of_their_own(tmp_path):
    # 60 trials of the hand on reach with seed 3: it means the longest reach every time, so nothing pins the
    # points' scale (beta at its smallest) and both intervals are the whole range
    fit = fit_reaches(read_reaches([simulated(tmp_path, "reach", "hand", 60, 3)])[0])
    assert all(low <= -1e5 and high >= 1e5 for low, high in fit.interval.values())
    assert [shown_points(fit, symbol) for symbol in "GC"] == ["any", "any"]
    assert optima(fit).fitted is None and [name for _, name in optima(fit).shown] == ["true"]
    assert all(np.isnan(row.estimate) for row in interval_rows(fit))
