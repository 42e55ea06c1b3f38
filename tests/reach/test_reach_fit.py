"""The reach fit: its likelihood against a brute-force sum, the identified set of an expected-gain maximiser
holding the truth and ordering the penalties, a soft-optimal player's points recovered inside their
intervals, the spread law from the endpoints, and `careful fit`'s JSON and one-line refusals."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from careful_tui.cli import main
from irl_core.errors import BadInputError
from irl_core.reach.fit import fit_reaches, soft_objective
from irl_core.reach.gain import choice_grid, soft_choice_log_probabilities
from irl_core.reach.players import reacher, simulate_reaches_to_file
from irl_core.recordings.reach_reader import read_reaches
from irl_core.worlds.reach import REACH_WORLDS


def simulated(tmp_path, name, policy, trials, seed, beta=0.2):
    world = REACH_WORLDS[name]
    path = tmp_path / f"{name}-{policy}-{seed}.jsonl"
    simulate_reaches_to_file(path, world, reacher(world, policy, beta=beta), trials=trials, seed=seed)
    return path


def test_the_likelihood_and_its_gradient_agree_with_a_brute_force_sum(tmp_path):
    reaches, _ = read_reaches([simulated(tmp_path, "reach", "boltzmann", 12, 0)])
    world = reaches.world
    grid = choice_grid(world)
    columns = grid.nearest_duration(reaches.durations)
    cost = np.broadcast_to(grid.cost[None, :], grid.hits.shape[1:])
    objective = soft_objective(grid, grid.hits, cost, reaches.aims, columns)
    w, beta, sigma = np.array([80.0, -300.0]), 0.3, 3.0
    # The independent route: pi from the gain module, then each trial's mixture summed aim by aim.
    pi = np.exp(soft_choice_log_probabilities(grid, w, beta))
    brute = -sum(np.log(pi[:, j] @ multivariate_normal(aim, sigma**2).pdf(grid.aims))
                 for aim, j in zip(reaches.aims, columns))
    params = np.array([*(beta * w), beta, np.log(sigma)])
    value, gradient = objective(params)
    assert value == pytest.approx(brute, rel=1e-9)
    steps = np.eye(4) * 1e-6 * np.maximum(1, np.abs(params))
    numeric = [(objective(params + h)[0] - objective(params - h)[0]) / (2 * h.max()) for h in steps]
    assert gradient == pytest.approx(numeric, rel=1e-4, abs=1e-4)


def test_the_maximisers_identified_sets_hold_the_truth_and_order_the_penalties(tmp_path):
    fits = {name: fit_reaches(read_reaches([simulated(tmp_path, name, "optimal", 50, 1)])[0])
            for name in ("reach-mild", "reach", "reach-severe")}
    for name, fit in fits.items():
        assert fit.interval_kind == "identified" and {note.code for note in fit.notes} >= {"one_choice"}
        for symbol, truth in REACH_WORLDS[name].points.items():
            low, high = fit.interval[symbol]
            assert low <= fit.reward[symbol] <= high and low <= truth <= high, (name, symbol)
    assert fits["reach-mild"].reward["C"] > fits["reach"].reward["C"] > fits["reach-severe"].reward["C"]


def test_a_known_target_pins_the_penalty_of_a_maximiser(tmp_path):
    fit = fit_reaches(read_reaches([simulated(tmp_path, "reach", "optimal", 20, 2)])[0], known={"G": 100.0})
    assert fit.reward["G"] == 100.0 and fit.interval["G"] == (100.0, 100.0)
    assert fit.reward["C"] == pytest.approx(-500, rel=0.2) and fit.interval["C"][0] < -500 < fit.interval["C"][1]


def test_a_soft_optimal_players_points_are_recovered_inside_their_intervals(tmp_path):
    fit = fit_reaches(read_reaches([simulated(tmp_path, "reach", "boltzmann", 300, 5)])[0], spread_known=True)
    assert fit.interval_kind == "confidence" and fit.interval_method == "laplace"
    for symbol, truth in REACH_WORLDS["reach"].points.items():
        low, high = fit.interval[symbol]
        assert low < fit.reward[symbol] < high and low < truth < high
    assert fit.reward["C"] == pytest.approx(-500, rel=0.3)
    assert fit.beta == pytest.approx(0.2, rel=0.3) and fit.aim_sd == pytest.approx(2.0, rel=0.3)


def test_the_spread_law_is_fitted_from_the_endpoints(tmp_path):
    # A player that varies its durations (a low beta) lets a and b be told apart.
    reaches, _ = read_reaches([simulated(tmp_path, "reach", "boltzmann", 400, 6, beta=0.05)])
    fit = fit_reaches(reaches)
    assert not fit.spread.known and fit.spread.interval is not None
    truth = REACH_WORLDS["reach"].spread
    assert fit.spread.interval["a"][0] <= truth.a <= fit.spread.interval["a"][1]
    assert fit.spread.interval["b"][0] <= truth.b <= fit.spread.interval["b"][1]
    # The sd it gives where the reaches were is close to the truth's.
    x = reaches.world.distance(reaches.aims) / (reaches.durations / 1000)
    assert np.median(fit.spread.spread.a + fit.spread.spread.b * x) == pytest.approx(np.median(truth.a + truth.b * x),
                                                                                     rel=0.1)


def test_a_world_whose_time_costs_nothing_is_refused(tmp_path):
    reaches, _ = read_reaches([simulated(tmp_path, "reach", "boltzmann", 5, 0)])
    free = reaches.world.model_copy(update={"cost_per_second": 0.0})
    with pytest.raises(BadInputError, match="nothing fixes the points' scale"):
        fit_reaches(type(reaches)(free, reaches.aims, reaches.durations, reaches.endpoints, 1))


def test_careful_fit_writes_the_reach_json(tmp_path, capsys):
    recording = simulated(tmp_path, "reach", "boltzmann", 150, 3)
    out = tmp_path / "fit.json"
    assert main(["fit", str(recording), "--json", str(out), "--no-view"]) == 0
    printed = capsys.readouterr().out
    assert "reach fit of reach: 150 trials from 1 file" in printed and "spread law (fitted" in printed
    answer = json.loads(out.read_text())
    assert set(answer["reward"]) == set(answer["interval"]) == {"G", "C"}
    assert set(answer["spread"]) == {"a", "b", "interval", "known"} and answer["spread"]["known"] is False
    assert set(answer["spread"]["interval"]) == {"a", "b"}
    assert answer["interval_kind"] == "confidence" and answer["interval_method"] == "laplace"
    for symbol, (low, high) in answer["interval"].items():
        assert low <= answer["reward"][symbol] <= high
    before = recording.read_bytes()
    assert main(["fit", str(recording), "--json", str(recording)]) == 2  # never over the recording it reads
    assert recording.read_bytes() == before and "--json" in capsys.readouterr().err


@pytest.mark.parametrize(("extra", "words"), [
    (["--svg", "x.svg"], "--svg: there is no text picture of a reach fit"),
    (["--figure", "x.gif"], "a figure must end in .pdf, .png, .svg"),
    (["--known", "U=-3"], "--known U: the reach world has no circle of that symbol"),
])
def test_careful_fit_refuses_what_a_reach_fit_cannot_do_in_one_line(tmp_path, capsys, extra, words):
    recording = simulated(tmp_path, "reach", "boltzmann", 5, 3)
    assert main(["fit", str(recording), "--no-view", *extra]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and words in error


def test_careful_fit_refuses_a_reach_and_a_grid_recording_together(tmp_path, capsys):
    grid = tmp_path / "grid.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "2", "--seed", "0",
                 "--out", str(grid)]) == 0
    assert main(["fit", str(simulated(tmp_path, "reach", "boltzmann", 5, 3)), str(grid), "--no-view"]) == 2
    assert "is not a reach recording" in capsys.readouterr().err


def test_careful_fit_names_the_bad_line_of_a_reach_recording(tmp_path, capsys):
    recording = simulated(tmp_path, "reach", "boltzmann", 5, 3)
    lines = recording.read_text().splitlines()
    step = json.loads(lines[2])
    lines[2] = json.dumps({**step, "duration_ms": 2000.0})
    recording.write_text("\n".join(lines) + "\n")
    assert main(["fit", str(recording), "--no-view"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and f"{recording}:3: duration_ms: 2000 is outside" in error


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(penalty=st.floats(-3000, -50), policy=st.sampled_from(["optimal", "boltzmann"]), trials=st.integers(15, 60),
       seed=st.integers(0, 2**16), known=st.booleans())
def test_every_fitted_point_lies_inside_its_interval(tmp_path_factory, penalty, policy, trials, seed, known):
    base = REACH_WORLDS["reach"]
    world = base.model_copy(update={"regions": (base.regions[0], base.regions[1].model_copy(update={"points": penalty}))})
    path = tmp_path_factory.mktemp("fit") / "r.jsonl"
    simulate_reaches_to_file(path, world, reacher(world, policy, beta=0.2), trials=trials, seed=seed)
    fit = fit_reaches(read_reaches([path])[0], known={"G": 100.0} if known else None)
    for symbol, (low, high) in fit.interval.items():
        assert low <= fit.reward[symbol] <= high, (symbol, fit.reward, fit.interval)


def test_options_of_the_other_kind_of_fit_are_named_and_ignored(tmp_path, capsys):
    assert main(["fit", str(simulated(tmp_path, "reach-mild", "optimal", 5, 0)), "--no-view", "--tie",
                 "--resamples", "50"]) == 0
    assert "--tie and --resamples apply only to grid worlds; ignored" in capsys.readouterr().err
    grid = tmp_path / "grid.jsonl"
    assert main(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "3", "--seed", "0",
                 "--out", str(grid)]) == 0
    capsys.readouterr()
    assert main(["fit", str(grid), "--no-view", "--spread-known"]) == 0
    assert "--spread-known applies only to reach worlds; ignored" in capsys.readouterr().err
