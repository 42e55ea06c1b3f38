"""A study's protocol (issue 45): every field of the study file strict, `study plan --players` checked
against the study's worlds before anything runs, a calibration block only where it can be asked, and no
folder the tool writes read as a participant."""

from __future__ import annotations

import pytest
from hardening_checks import assert_refused, careful

STUDY = 'name = "pilot"\nworlds = ["mud"]\npractice_episodes = 0\nepisodes = 3\n'


@pytest.mark.parametrize("value", ["true", "false", '"0.5"'])
def test_max_quit_share_is_a_number_never_a_boolean_or_text(capsys, tmp_path, value):
    study = tmp_path / "s.toml"
    study.write_text(STUDY + f"[exclusions]\nmax_quit_share = {value}\n")
    assert_refused(*careful(capsys, "study", "report", study), str(study), "exclusions.max_quit_share")


@pytest.mark.parametrize(("value", "share"), [("0", 0.0), ("1", 1.0), ("0.25", 0.25)])
def test_max_quit_share_takes_whole_and_decimal_numbers(tmp_path, value, share):
    from irl_core.studies.study import load_study

    study = tmp_path / "s.toml"
    study.write_text(STUDY + f"[exclusions]\nmax_quit_share = {value}\n")
    assert load_study(study).study.exclusions.max_quit_share == share


@pytest.mark.parametrize("players", ["timed,steady", "timing", "loose,nobody"])
def test_plan_refuses_a_player_its_worlds_cannot_have_before_simulating(capsys, tmp_path, players):
    """The plan simulates worlds with levels only: a time world's player (timing, steady) is refused with the
    choices, exit 2, before the simulation starts (nothing written)."""
    study = tmp_path / "s.toml"
    study.write_text(STUDY)
    line = assert_refused(*careful(capsys, "study", "plan", study, "--players", players, "--participants", "2",
                                   "--episodes", "2", "--repeats", "1", "--workers", "1"),
                          "--players", "loose, timed, hasty, inverted, reckless")
    assert "unexpected" not in line
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize(("worlds", "order", "named"), [
    ('["paper-time", "mud"]', "fixed", "worlds[0]"),
    ('["mud", "paper-time"]', "shuffled", "worlds[1]"),
])
def test_a_calibration_block_is_refused_where_a_time_world_can_come_first(capsys, tmp_path, worlds, order, named):
    """The block's targets are levels of the participant's first world, and a time world has none
    (docs/timing.md: no calibration on a time world): the study file is refused, one line naming the field."""
    study = tmp_path / "s.toml"
    study.write_text(f'worlds = {worlds}\norder = "{order}"\ninput = "hold"\ncalibration_block = 16\n')
    assert_refused(*careful(capsys, "study", "run", study, "--participant", "p1"),
                   str(study), "calibration_block", named, "time world")


def test_a_calibration_block_before_a_fixed_level_world_keeps_its_time_worlds(tmp_path):
    from irl_core.studies.study import load_study

    study = tmp_path / "s.toml"
    study.write_text('worlds = ["mud", "paper-time"]\norder = "fixed"\ninput = "hold"\ncalibration_block = 4\n')
    assert load_study(study).study.calibration_block == 4


def test_the_report_never_reads_the_planners_folder_as_a_participant(capsys, tmp_path):
    """`study plan` writes `<out>/plan/`; the report then read it as a participant with no episodes and counted
    one participant too many. The folders the tool writes are never participants, nor their names ids."""
    from study.conftest import write_block

    from irl_core.errors import StudyError
    from irl_core.studies.report import participant_ids
    from irl_core.studies.study import check_participant, load_study

    path = tmp_path / "s.toml"
    path.write_text(STUDY)
    study = load_study(path)
    write_block(study, "p1", 0, "main", name="a.jsonl", finished=3)
    (study.out / "plan").mkdir()
    (study.out / "plan" / "plan.csv").write_text("world,participants\n")
    (study.out / "report").mkdir()
    assert participant_ids(study) == (["p1"], [])
    for taken in ("plan", "Plan", "report"):
        with pytest.raises(StudyError, match="is taken"):
            check_participant(taken)


@pytest.mark.parametrize("show_rewards", [True, False, None])
def test_both_front_ends_tell_a_studys_participants_the_same_legend(tmp_path, show_rewards):
    """The terminal's legend gave `cliff -1000 · goal 100 · mud -30`, the browser's names only; now the study
    file's `show_rewards` (default true) decides both, from one list of entries."""
    from starlette.testclient import TestClient
    from web.conftest import Api, web_app

    from careful_tui.render.session import legend
    from irl_core.studies.flow import block_options
    from irl_core.studies.study import load_study, read_protocol

    path = tmp_path / "s.toml"
    path.write_text('worlds = ["mud"]\ninput = "hold"\npractice_episodes = 0\nepisodes = 1\nout = "data"\n'
                    + ("" if show_rewards is None else f"show_rewards = {str(show_rewards).lower()}\n"))
    study = load_study(path)
    shown = show_rewards is not False
    app, tokens = web_app(study)
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        browser = api.view["play"]["legend"]
    protocol = read_protocol(study, "p002")
    options = block_options(protocol, protocol.next_block, "p002", None)
    terminal = legend(study.worlds[0], show_rewards=options.show_rewards).plain
    words = [f"{name} {reward}" if reward is not None else name for _, name, reward, _ in browser]
    assert terminal == " · ".join(f"■ {w}" + (" (ends)" if ends else "") for w, (*_, ends) in zip(words, browser))
    assert ("cliff -1000" in terminal) == shown and ("-1000" in str(browser)) == shown
    assert [name for _, name, _, _ in browser] == ["cliff", "goal", "mud"]


def test_show_rewards_is_a_boolean(capsys, tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(STUDY + 'show_rewards = "no"\n')
    assert_refused(*careful(capsys, "study", "report", study), str(study), "show_rewards")
