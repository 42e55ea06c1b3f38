"""The timing fit (docs/timing.md): its best holds and slip curve against independent routes, and its answer on
players it does not contain."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.irl import fit
from irl_core.irl.qmap import build_unknowns
from irl_core.irl.timing.fit import timing_plan
from irl_core.irl.timing.slip_curve import fit_slip_curve
from irl_core.players.experts import demonstrations_of, optimal_plan, rollouts
from irl_core.players.person_like import best_holds, person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from bench.bench_timing import pooled_players  # noqa: E402

MUD_TIME = BUILTIN_WORLDS["mud-time"]


def test_the_closed_form_best_hold_is_the_best_of_a_fine_grid_of_holds():
    mdp = build_mdp(MUD_TIME)
    plan = timing_plan(mdp, mdp.R_S, p0=0.5, p_inf=0.0, tau_ms=400.0, cost_per_second=5.0)
    assert plan.converged
    # For the plan's own values, search every hold on a grid of 20,000: the closed form must be its argmax.
    grid = np.linspace(20.0, MUD_TIME.max_hold_ms, 20_000)
    slip = 0.5 * np.exp(-grid / 400.0)
    for s in np.flatnonzero(mdp.nonterminal):
        for d in range(4):
            ahead = plan.V[mdp.neighbour[s, d]]
            others = (plan.V[mdp.neighbour[s]].sum() - ahead) / 3
            q = mdp.R_S[s] - 5.0 * grid / 1000 + mdp.gamma * ((1 - slip) * ahead + slip * others)
            assert plan.Q[s, d] == pytest.approx(q.max(), abs=1e-6)
            if q.argmax() not in (0, grid.size - 1):
                assert plan.hold[s, d] == pytest.approx(grid[q.argmax()], abs=1.0)
    # Choosing holds freely is never worse than choosing among 16 bins, and not much better.
    binned = optimal_plan(mdp).V
    acting = mdp.nonterminal
    assert np.all(plan.V[acting] >= binned[acting] - 1e-9) and np.all(plan.V[acting] - binned[acting] < 1.0)


def test_the_person_like_players_best_hold_is_the_fits_for_the_same_values():
    mdp = build_mdp(MUD_TIME)
    plan = timing_plan(mdp, mdp.R_S, p0=0.5, p_inf=0.0, tau_ms=400.0, cost_per_second=5.0)
    d_star = plan.Q.argmax(axis=1)
    grid_holds = best_holds(mdp, plan.V, d_star)  # the simulator's own search, over a log grid
    acting = np.flatnonzero(mdp.nonterminal)
    closed = plan.hold[acting, d_star[acting]]
    assert grid_holds[acting] == pytest.approx(closed, rel=0.01)


def test_the_slip_curve_is_the_likelihoods_maximum_and_its_intervals_hold_the_truth():
    rng = np.random.default_rng(4)
    hold = np.exp(rng.uniform(np.log(50), np.log(3000), 3000))
    slipped = rng.random(hold.size) < 0.05 + 0.4 * np.exp(-hold / 300)
    curve = fit_slip_curve(np.column_stack([hold, slipped]), max_hold_ms=4000.0)
    # An independent route: the best of a grid over the three parameters.
    best, where = -np.inf, None
    for p0 in np.linspace(0.3, 0.6, 31):
        for p_inf in np.linspace(0.0, 0.1, 21):
            for tau in np.linspace(200, 420, 45):
                p = np.clip(p_inf + (p0 - p_inf) * np.exp(-hold / tau), 1e-12, 1 - 1e-12)
                ll = np.sum(np.where(slipped, np.log(p), np.log1p(-p)))
                if ll > best:
                    best, where = ll, (p0, p_inf, tau)
    # Within a grid step (and the grid's own coarseness) of the grid's best.
    assert curve.p0 == pytest.approx(where[0], abs=0.02)
    assert curve.p_inf == pytest.approx(where[1], abs=0.01)
    assert curve.tau_ms == pytest.approx(where[2], abs=10.0)
    assert curve.interval is not None
    for name, truth in (("p0", 0.45), ("p_inf", 0.05), ("tau_ms", 300.0)):
        low, high = curve.interval[name]
        assert low <= truth <= high


@pytest.fixture(scope="module")
def careful_players():
    return pooled_players(build_mdp(MUD_TIME), "timing", seed=11, players=12, episodes=20)


def test_the_fit_of_timing_players_it_does_not_contain_finds_the_cliff_and_the_curve(careful_players):
    result = fit(careful_players, tie=True, intervals=True, rmax=5000.0)
    got = dict(zip(result.unknowns.labels, result.theta))
    assert (result.method, result.player_model) == ("maxent", "timing") and result.slip_curve is not None and not result.slip_curve.known
    assert abs(got["C"] / got["U"] / (1000 / 30) - 1) < 0.25
    assert abs(result.slip_curve.tau_ms / 400 - 1) < 0.1
    assert result.intervals is not None
    for (low, high), label in zip(result.intervals, result.unknowns.labels):
        assert low <= {"C": -1000.0, "U": -30.0, "G": 100.0}[label] <= high
    assert "cliff_not_separated" not in [n.code for n in result.notes]
    assert result.evaluation.agent.ends["C"] < 0.01
    seconds = fit(careful_players, tie=True, cost="unknown", rmax=5000.0)
    assert seconds.reward_unit == "seconds of holding"
    assert dict(zip(seconds.unknowns.labels, seconds.theta))["C"] == pytest.approx(got["C"] / 5.0, rel=0.02)


def test_a_player_whose_hold_ignores_danger_is_not_read_as_fearing_the_cliff():
    demos = pooled_players(build_mdp(MUD_TIME), "steady", seed=5, players=12, episodes=20, hold_ms=600.0)
    result = fit(demos, tie=True, intervals=True, rmax=5000.0)
    assert "cliff_not_separated" in [n.code for n in result.notes]
    assert result.fit_check is not None and result.fit_check.passed is False


def _simulate(tmp_path: Path, world: str, policy: str, episodes: int = 40) -> Path:
    out = tmp_path / f"{world}-{policy}.jsonl"
    assert main(["simulate", "--world", world, "--policy", policy, "--episodes", str(episodes), "--seed", "3",
                 "--out", str(out)]) == 0
    return out


def test_the_json_says_the_curve_and_the_unit(tmp_path: Path, capsys):
    recording = _simulate(tmp_path, "mud-time", "timing")
    out = tmp_path / "fit.json"
    assert main(["fit", str(recording), "--tie", "--cost", "unknown", "--json", str(out), "--no-view"]) == 0
    data = json.loads(out.read_text())
    assert data["reward_unit"] == "seconds of holding" and data["world"] == MUD_TIME.model_dump(mode="json")
    curve = data["slip_curve"]
    assert set(curve) == {"p0", "p_inf", "tau_ms", "interval", "known"} and curve["known"] is False
    assert set(curve["interval"]) == {"p0", "p_inf", "tau_ms"}
    assert data["options"]["cost"] == "unknown" and data["options"]["slip_known"] is False
    printed = capsys.readouterr().out
    assert "seconds of holding" in printed and "slip curve fitted" in printed


@pytest.mark.parametrize("world, flags, words", [
    ("mud", ["--slip-known"], "is for a time world"),
    ("mud-time", ["--method", "lp"], "cannot learn one"),
])
def test_a_time_option_where_it_cannot_apply_is_one_clear_line(tmp_path: Path, capsys, world, flags, words):
    recording = _simulate(tmp_path, world, "optimal", episodes=5)
    capsys.readouterr()
    assert main(["fit", str(recording), *flags, "--no-view"]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1


def test_the_slip_known_fit_plans_with_the_worlds_own_curve(tmp_path: Path):
    mdp = build_mdp(MUD_TIME)
    demos = demonstrations_of(mdp, rollouts(mdp, person_like(mdp, "timing").choose, episodes=60, seed=2))
    result = fit(demos, tie=True, slip_known=True)
    assert result.slip_curve is not None and result.slip_curve.known
    assert (result.slip_curve.p0, result.slip_curve.tau_ms) == (0.5, 400.0)
    assert build_unknowns(mdp, reward_cells="special", tie=True).labels == result.unknowns.labels


def test_the_fit_figure_of_a_time_world_draws_the_slip_curve_and_the_holds(careful_players):
    from careful_tui.render.figures.fit_figure import fit_figure

    result = fit(careful_players, tie=True, intervals=True, rmax=5000.0)
    figure = fit_figure(result)
    axes = {ax.get_label(): ax for ax in figure.get_axes()}
    assert {"slip curve", "holds", "policy", "intervals"} <= set(axes) and "carefulness" not in axes
    curve_lines = [line for line in axes["slip curve"].get_lines() if line.get_label() == "fitted curve"]
    (line,) = curve_lines
    x, y = line.get_data()
    expected = result.slip_curve.p_inf + (result.slip_curve.p0 - result.slip_curve.p_inf) * np.exp(
        -np.asarray(x) / result.slip_curve.tau_ms)
    assert np.allclose(y, expected)
    fitted = [line for line in axes["holds"].get_lines() if line.get_label() == "fitted player's intended hold"]
    assert fitted and np.all(np.diff(fitted[0].get_ydata()) < 0)  # the intended hold shortens away from danger


def test_on_play_drawn_from_the_timing_model_itself_the_fit_check_passes_and_the_rewards_return():
    from irl_core.irl.timing.fit import TimingFit, timing_chooser
    from irl_core.irl.timing.slip_curve import SlipCurve

    mdp = build_mdp(MUD_TIME)
    plan = timing_plan(mdp, mdp.R_S, p0=0.5, p_inf=0.0, tau_ms=400.0, cost_per_second=5.0)
    truth = TimingFit(theta=np.zeros(0), curve=SlipCurve(0.5, 0.0, 400.0, known=True), beta=1.0, sigma=0.25,
                      lapse=0.1, plan=plan, mean_log_likelihood=0.0, converged=True, message="",
                      theta_intervals=None)
    demos = demonstrations_of(mdp, rollouts(mdp, timing_chooser(mdp, truth), episodes=400, seed=0))
    result = fit(demos, tie=True, rmax=5000.0)
    got = dict(zip(result.unknowns.labels, result.theta))
    assert result.fit_check is not None and result.fit_check.passed is True
    assert abs(got["C"] / got["U"] / (1000 / 30) - 1) < 0.2 and abs(got["G"] / 100 - 1) < 0.2
