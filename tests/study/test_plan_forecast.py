"""`careful study plan --fits report`: each simulated study fitted by the report's own machinery, so the plan's
covered column is what `careful study report` shows on such a study (issue: the plan said 0-10%, reports 65-80%)."""

import csv

import numpy as np
import pytest

from careful_tui.cli import main
from irl_core.errors import PlanError
from irl_core.irl.qmap import build_unknowns
from irl_core.players.experts import rollouts
from irl_core.studies.forecast import reported_intervals, write_simulated_study
from irl_core.studies.plan import PlanGrid, plan_study, simulate_repeat
from irl_core.studies.study import Exclusions
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

RESAMPLES = 20  # the fewest a report takes


def participants(mdp, episodes=4):
    from irl_core.players.person_like import person_like

    out = []
    for i, kind in enumerate(("loose", "timed", "hasty")):
        player = person_like(mdp, kind)
        out.append((player.player, rollouts(mdp, player.choose, episodes=episodes, rng=np.random.default_rng(i))))
    return out


def test_the_plans_report_fit_is_the_pooled_row_careful_study_report_writes_for_that_study(tmp_path, capsys):
    world = BUILTIN_WORLDS["mud"]
    mdp = build_mdp(world)
    played, none = participants(mdp), [np.zeros((0, 2), dtype=np.int64)] * 3
    unknowns = build_unknowns(mdp, tie=True)
    got = reported_intervals(world, unknowns, played, none, calibration=0, pool="population", resamples=RESAMPLES,
                             rmax=5000.0, exclusions=Exclusions(), seed=7)
    # The same study written where a user runs the report on it, through the command line.
    path = write_simulated_study(tmp_path, world, played, none, calibration=0, seed=7)
    assert main(["study", "report", str(path), "--resamples", str(RESAMPLES), "--seed", "7", "--workers", "1"]) == 0
    capsys.readouterr()
    with open(tmp_path / "data" / "report" / "report.csv", newline="") as file:
        pooled = next(row for row in csv.DictReader(file) if row["participant"] == "pooled")
    for j, symbol in enumerate(unknowns.symbols):
        expected = [float(pooled[f"reward_{symbol}_low"]), float(pooled[f"reward_{symbol}_high"])]
        assert got[j] == pytest.approx(expected, rel=1e-5, abs=1e-6), symbol  # the CSV keeps 6 figures


def test_a_grid_point_counts_its_studies_reports_and_shares_its_random_numbers_with_the_plans_fit():
    grid = PlanGrid(participants=(2,), episodes=(3,), repeats=2, fits="report", resamples=RESAMPLES)
    (point,) = plan_study((BUILTIN_WORLDS["mud"],), grid)
    assert point.studies == 2 and point.covered in (0.0, 0.5, 1.0)
    assert set(point.width) == set(point.symbols)
    # Both fits see the same simulated participants (common random numbers): only the fitting differs.
    quick = simulate_repeat(BUILTIN_WORLDS["mud"], PlanGrid(participants=(2,), episodes=(3,), repeats=1), 0)
    reported = simulate_repeat(BUILTIN_WORLDS["mud"], PlanGrid(participants=(2,), episodes=(3,), repeats=1,
                                                               fits="report", resamples=RESAMPLES), 0)
    assert quick[(2, 3)].intervals.shape == reported[(2, 3)].intervals.shape


@pytest.mark.parametrize(("field", "value"), [("fits", "bootstrap"), ("resamples", 19)])
def test_a_plan_refuses_fits_it_does_not_know(field, value):
    with pytest.raises(PlanError) as caught:
        PlanGrid(**{field: value})
    assert caught.value.field == field


def test_the_command_line_names_the_choices_of_fits(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text('name = "t"\nworlds = ["mud"]\nepisodes = 3\nout = "data"\n')
    with pytest.raises(SystemExit) as stopped:
        main(["study", "plan", str(study), "--fits", "bootstrap"])
    assert stopped.value.code == 2
    assert "choose from 'plan', 'report'" in capsys.readouterr().err
