"""`careful study plan` on a tiny grid: the pool, the shares, the files, and bad input refused in one line."""

import csv

import pytest
from study.conftest import write_study

from careful_tui.cli import main
from irl_core.studies.plan import PlanError, PlanGrid, plan_study, planned_worlds
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
                                    dict(players=("brave",)), dict(repeats=0)])
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
    assert [(r["participants"], r["episodes"], r["studies"], r["truth_C"], r["truth_U"]) for r in rows] == [
        ("2", "3", "2", "-800", "-20")]
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
