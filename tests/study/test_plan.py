"""`careful study plan` on a tiny grid: the pool, the shares, the files, and bad input refused in one line."""

import csv

import numpy as np
import pytest
from study.conftest import write_study

import irl_core.studies.plan as plan
from careful_tui.cli import main
from irl_core.errors import PlanError
from irl_core.studies.plan import (
    PlanGrid,
    block_targets,
    calibration_block,
    drawn_player,
    plan_study,
    planned_worlds,
    simulate_repeat,
)
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

TINY = PlanGrid(participants=(2, 3), episodes=(3,), repeats=2)
TINY_SHARED = PlanGrid(participants=(2, 3), episodes=(3,), repeats=2, pool="shared")


@pytest.fixture(scope="module")
def tiny_plan():
    worlds = planned_worlds((BUILTIN_WORLDS["mud"], BUILTIN_WORLDS["paper"]), {"C": -800.0})
    return worlds, plan_study(worlds, TINY)


def test_every_world_and_grid_point_gets_shares_of_its_simulated_studies(tiny_plan):
    worlds, points = tiny_plan
    assert [(p.world, p.participants, p.episodes) for p in points] == [
        ("mud", 2, 3), ("mud", 3, 3), ("paper", 2, 3), ("paper", 3, 3)]
    for p in points:
        assert p.studies == 2
        assert p.covered in (0.0, 0.5, 1.0)
        assert dict(zip(p.symbols, p.truth))["C"] == -800.0
        assert all(w >= 0 for w in p.width.values())
    # paper has no nuisance to separate from the cliff
    assert [p.separated is None for p in points] == [False, False, True, True]


def test_the_shared_pool_plans_the_same_points():
    worlds = planned_worlds((BUILTIN_WORLDS["mud"],), {})
    points = plan_study(worlds, TINY_SHARED)
    assert [(p.participants, p.studies) for p in points] == [(2, 2), (3, 2)]
    assert all(0 <= p.covered <= 1 and p.separated is not None for p in points)


def test_the_same_seed_plans_the_same(tiny_plan):
    worlds, points = tiny_plan
    again = plan_study(worlds[:1], TINY, workers=2)
    assert again == points[:2]


@pytest.mark.parametrize("option", [dict(participants=(0, 5)), dict(participants=(10**6,)), dict(episodes=()),
                                    dict(players=("brave",)), dict(repeats=0), dict(calibration=-1),
                                    dict(calibration=101), dict(model="timing"), dict(model="brave")])
def test_a_bad_grid_names_its_field(option):
    with pytest.raises(PlanError) as raised:
        PlanGrid(**option)
    assert raised.value.field == next(iter(option))


def test_careful_study_plan_writes_csv_and_figures(tmp_path, capsys):
    path = write_study(tmp_path, worlds='["mud"]')
    status = main(["study", "plan", str(path), "--participants", "2", "--episodes", "3", "--repeats", "2",
                   "--truth", "C=-800,U=-20", "--workers", "1"])
    out, err = capsys.readouterr()
    assert status == 0
    assert "separated" in out and "mud:" in out
    folder = tmp_path / "data" / "plan"
    assert sorted(p.name for p in folder.iterdir()) == ["plan.csv", "plan.pdf", "plan.png"]
    rows = list(csv.DictReader((folder / "plan.csv").open()))
    assert [(r["participants"], r["episodes"], r["studies"], r["calibration"], r["truth_C"], r["truth_U"])
            for r in rows] == [("2", "3", "2", "0", "-800", "-20")]
    assert float(rows[0]["separated"]) in (0.0, 0.5, 1.0)
    assert (folder / "plan.pdf").read_bytes().startswith(b"%PDF")


@pytest.mark.parametrize(("argv", "field"), [
    (["--participants", "0"], "--participants"),
    (["--participants", "1000000"], "--participants"),
    (["--participants", "5,ten"], "--participants"),
    (["--episodes", "0"], "--episodes"),
    (["--truth", "X=-5"], "--truth"),
    (["--truth", "C=-inf"], "--truth"),
    (["--truth", "C=-6000"], "--truth"),
    (["--truth", "#=5"], "--truth"),
    (["--players", "loose,brave"], "--players"),
    (["--calibration", "-1"], "--calibration"),
    (["--calibration", "500"], "--calibration"),
    (["--player-model", "timing"], "--player-model"),
])
def test_bad_input_is_one_line_naming_the_field(tmp_path, capsys, argv, field):
    path = write_study(tmp_path, worlds='["mud"]')
    try:
        status = main(["study", "plan", str(path), *argv])
    except SystemExit as exc:
        status = int(exc.code or 0)
    out, err = capsys.readouterr()
    assert status == 2
    assert len(err.strip().splitlines()) == 1 and field in err
    assert not (tmp_path / "data" / "plan").exists()


def test_an_interrupted_plan_leaves_no_figure_under_its_final_name(tmp_path, capsys, monkeypatch):
    from matplotlib.figure import Figure

    def interrupted(self, *args, **kwargs):  # Ctrl+C while the figure is drawn
        raise KeyboardInterrupt

    monkeypatch.setattr(Figure, "savefig", interrupted)
    path = write_study(tmp_path, worlds='["mud"]')
    status = main(["study", "plan", str(path), "--participants", "2", "--episodes", "2", "--repeats", "1",
                   "--workers", "1"])
    assert status != 0 and "interrupted" in capsys.readouterr().err
    folder = tmp_path / "data" / "plan"
    assert [p.name for p in folder.iterdir()] == ["plan.csv"]  # whole; no figure, nothing half-written beside
    assert (folder / "plan.csv").read_text().count("\n") == 2


def test_a_calibration_block_measures_each_simulated_hand():
    world = BUILTIN_WORLDS["mud"]
    mdp = build_mdp(world)
    rng = np.random.default_rng(3)
    trials = calibration_block(drawn_player(mdp, "hasty", 0.0, rng), world, 40, rng)
    assert trials.shape == (40, 2)
    assert set(trials[:, 0]) == set(range(2, world.levels + 1))  # every level asked, as a study asks them
    assert -3.0 < (trials[:, 1] - trials[:, 0]).mean() < -1.0  # hasty holds two levels short
    # No levels to hold for: no block.
    assert block_targets(BUILTIN_WORLDS["paper-time"], PlanGrid(calibration=10)) == 0
    assert block_targets(BUILTIN_WORLDS["paper-simple"], PlanGrid(calibration=10)) == 0


@pytest.mark.parametrize("pool", ["population", "shared"])
def test_the_fits_hold_the_hand_the_block_measured(monkeypatch, pool):
    held = []
    fit_given_model = plan.fit_given_model

    def recording(mdp, unknowns, counts, *, model, rmax):
        held.append(model.known_hand)
        return fit_given_model(mdp, unknowns, counts, model=model, rmax=rmax)

    monkeypatch.setattr(plan, "fit_given_model", recording)
    grid = PlanGrid(participants=(2,), episodes=(3,), repeats=1, players=("hasty",), spread=0.0, calibration=20,
                    pool=pool)
    simulate_repeat(BUILTIN_WORLDS["mud"], grid, 0)
    assert held and all(hand is not None and -3.0 < hand[0] < -1.0 for hand in held)
    held.clear()
    simulate_repeat(BUILTIN_WORLDS["mud"], PlanGrid(participants=(2,), episodes=(3,), repeats=1, pool=pool), 0)
    assert held and all(hand is None for hand in held)


def test_a_block_leaves_the_simulated_play_as_it_was(monkeypatch):
    # The trials are drawn after the episodes: a plan with a block and one without see the same play, so the
    # two differ only by the hand.
    counts = []
    original = plan.demonstrations_of
    monkeypatch.setattr(plan, "demonstrations_of", lambda mdp, played: counts.append(original(mdp, played)) or counts[-1])
    for calibration in (0, 10):
        simulate_repeat(BUILTIN_WORLDS["mud"], PlanGrid(participants=(2,), episodes=(3,), repeats=1,
                                                        calibration=calibration, pool="shared"), 0)
    assert len(counts) == 4
    assert all(np.array_equal(a.counts, b.counts) for a, b in zip(counts[:2], counts[2:]))


def test_careful_study_plan_takes_the_block_from_the_study_file(tmp_path, capsys):
    path = write_study(tmp_path, worlds='["mud"]')
    path.write_text(path.read_text() + "\ncalibration_block = 6\n")
    status = main(["study", "plan", str(path), "--participants", "2", "--episodes", "3", "--repeats", "1",
                   "--workers", "1", "--player-model", "naive"])
    out, _ = capsys.readouterr()
    assert status == 0
    assert "a calibration block of 6 targets each" in " ".join(out.split()) and "naive model" in out
    rows = list(csv.DictReader((tmp_path / "data" / "plan" / "plan.csv").open()))
    assert [r["calibration"] for r in rows] == ["6"]


def test_a_studys_time_worlds_are_left_out_and_said_so(tmp_path, capsys):
    # The default players include timed, which holds a levels world's windows: a time world once crashed the plan.
    path = tmp_path / "pilot.toml"
    path.write_text('worlds = ["mud", "paper-time"]\ninput = "hold"\nout = "data"\n')
    assert main(["study", "plan", str(path), "--participants", "2", "--episodes", "2", "--repeats", "1",
                 "--workers", "1"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "paper-time: a time world, left out (the plan's simulated players and fits are those of worlds with levels)" in out
    rows = list(csv.DictReader((tmp_path / "data" / "plan" / "plan.csv").open()))
    assert [r["world"] for r in rows] == ["mud"]


def test_a_study_of_time_worlds_only_is_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "pilot.toml"
    path.write_text('worlds = ["paper-time"]\ninput = "hold"\nout = "data"\n')
    assert main(["study", "plan", str(path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "every world of the study is a time world" in err
    assert not (tmp_path / "data" / "plan").exists()


def test_the_findings_say_the_plans_coverage_is_a_floor_for_a_report():
    from careful_tui.commands.study_plan import plan_findings
    from irl_core.studies.plan import PlanPoint

    def point(covered):
        return PlanPoint(world="mud", participants=5, episodes=10, studies=20, calibration=0, symbols=("C", "U"),
                         truth=(-1000.0, -30.0), separated=0.9, covered=covered,
                         covered_each={"C": covered, "U": 1.0}, width={"C": 500.0, "U": 20.0})

    low, = plan_findings([point(0.15)])
    assert "5 participants of 10 episodes separate catastrophe from nuisance in 90%" in low
    assert "the plan's Laplace intervals miss the truth more often than their 95% says" in low
    assert "the cliff's held -1000 in 15%" in low and "read the share as a floor for a report" in low
    high, = plan_findings([point(0.9)])
    assert "in 90% of studies." in high and "floor" not in high
