"""Exclusions fixed before the data (a study file's ``[exclusions]``): read strictly, applied by `careful study
report` before pooling, listed with their reasons; ``--no-exclusions`` pools everyone and still names outliers."""

import csv

from test_pooling import person_like, write_participant

from careful_tui.cli import main
from irl_core.players.experts import boltzmann_policy
from irl_core.studies.report import POOLED, CellFit, excluded_why, gather
from irl_core.studies.study import Exclusions, load_study
from irl_core.worlds.mdp import build_mdp

STUDY = 'name = "pilot"\nworlds = ["mud"]\npractice_episodes = 0\nepisodes = {episodes}\n'


def test_an_unknown_or_bad_exclusion_is_one_line_naming_the_key(tmp_path, capsys):
    path = tmp_path / "s.toml"
    for table, named in (("[exclusions]\nmin_main_episode = 8\n", "exclusions.min_main_episode"),
                         ("[exclusions]\nmax_quit_share = 1.5\n", "exclusions.max_quit_share"),
                         ("[exclusions]\nmin_main_episodes = -1\n", "exclusions.min_main_episodes"),
                         ('[exclusions]\nfit_check_failed = "yes"\n', "exclusions.fit_check_failed")):
        path.write_text(STUDY.format(episodes=3) + table)
        assert main(["study", "report", str(path)]) == 2
        err = capsys.readouterr().err.strip()
        assert named in err and len(err.splitlines()) == 1


def test_each_rule_says_why(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(episodes=3))
    study = load_study(path)
    from study.conftest import write_block
    write_block(study, "p1", 0, "main", name="a.jsonl", finished=3)
    cell = gather(study).cell("p1", 0)
    rules = Exclusions(fit_check_failed=True, min_main_episodes=8, max_quit_share=0.5)
    assert excluded_why(cell, CellFit(fit_check_passed=False), rules) == (
        "fit check failed; 3 finished main episodes, fewer than 8")
    assert excluded_why(cell, CellFit(fit_check_passed=True), Exclusions(min_main_episodes=3)) is None
    assert excluded_why(cell, CellFit(fit_check_passed=False), Exclusions()) is None


def test_the_report_excludes_before_pooling_and_no_exclusions_pools_everyone(tmp_path, capsys):
    """A participant with 4 of 8 episodes is excluded by min_main_episodes = 6: their row stays, marked, with
    the reason; the population pools the others. --no-exclusions pools all five, says so, and the reckless
    participant is still named an outlier among the four others (exit 0)."""
    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(episodes=8) + "[exclusions]\nmin_main_episodes = 6\n")
    study = load_study(path)
    mdp = build_mdp(study.worlds[0])
    for i, beta in enumerate((0.8, 1.2, 2.0, 1.5)):
        write_participant(study, f"p{i + 1}", boltzmann_policy(mdp, beta=beta), seed=i)
    write_participant(study, "reckless", person_like(mdp, lapse=0.25, level_spread=0, level=1), seed=99)
    short = study.participant_folder("p4") / "p4-0-w0-main.jsonl"
    lines = short.read_text().splitlines(keepends=True)
    ends = [i for i, line in enumerate(lines) if '"episode_end"' in line]
    short.write_text("".join(lines[: ends[3] + 1]))  # 4 finished episodes of 8
    assert main(["study", "report", str(path), "--resamples", "20", "--workers", "2"]) == 0
    out = capsys.readouterr().out
    rows = {row["participant"]: row for row in csv.DictReader((study.report_folder / "report.csv").open())}
    assert rows["p4"]["excluded"] == "true" and rows["p4"]["excluded_why"] == (
        "4 finished main episodes, fewer than 6") and rows["p4"]["outlier"] == ""
    assert rows["p1"]["excluded"] == "false"
    assert "excluded from the mud pool by the study's [exclusions]: p4 (4 finished main episodes, fewer than 6)" in out
    assert "population (4)" in out
    assert main(["study", "report", str(path), "--resamples", "20", "--workers", "2", "--no-exclusions",
                 "--out", str(tmp_path / "all")]) == 0
    out = capsys.readouterr().out
    rows = {row["participant"]: row for row in csv.DictReader((tmp_path / "all" / "report.csv").open())}
    assert rows["p4"]["excluded"] == "false" and "population (5)" in out
    assert "were not applied (--no-exclusions)" in out
    assert rows["reckless"]["outlier"] == "true" and "reckless" in rows[POOLED]["finding"]
