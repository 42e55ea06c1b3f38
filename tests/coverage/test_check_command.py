"""`careful check` on the command line: bad input is one line and exit 2 (before any fit), check.csv is written
whole or not at all (Ctrl+C leaves none, or the earlier one as it was), and the same seed gives the same
check.csv on one worker and on a Dask LocalCluster of two started by the command inside this test."""


import json

import pytest

import careful_tui.commands.check as check_command
from careful_tui.cli import main
from irl_core.coverage.check import CSV_COLUMNS
from irl_core.players.experts import simulate_to_file
from irl_core.players.person_like import person_like
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import load_world

# Small and quick: the paper's Boltzmann expert with beta given, one unknown per symbol, 20 resamples.
QUICK = ["--tie", "--method", "maxent", "--beta", "1", "--resamples", "20"]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("check") / "loose.jsonl"
    mdp = build_mdp(load_world("mud"))
    simulate_to_file(path, mdp, person_like(mdp, "loose").choose, episodes=8, seed=1, player="person:loose")
    return path


def run(capsys, *argv):
    code = main(["check", *map(str, argv)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("datasets", ["0", "-3"])
def test_no_datasets_is_one_line_and_exit_2(recording, tmp_path, capsys, datasets):
    with pytest.raises(SystemExit) as exit_info:
        main(["check", str(recording), "--datasets", datasets, "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--datasets" in err and "at least 1" in err


def test_a_player_that_is_none_is_exit_2_with_the_choices(recording, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["check", str(recording), "--players", "loose,banana", "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "'banana' is not a player" in err and "loose, timed, hasty, inverted, reckless, timing, steady" in err


def test_a_player_of_the_other_kind_of_world_is_exit_2_with_this_worlds_choices_before_fitting(
        recording, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("careful_tui.commands.fit.fit", lambda *a, **k: pytest.fail("fitted before refusing"))
    code, _, err = run(capsys, recording, "--players", "timing", "--out", tmp_path)
    assert code == 2
    assert "timing holds for a time" in err and "loose, timed, hasty, inverted, reckless" in err
    assert not (tmp_path / "check.csv").exists()


def test_ctrl_c_leaves_no_check_csv_and_an_earlier_one_as_it_was(recording, tmp_path, capsys, monkeypatch):
    def interrupted(*args, progress, **kwargs):
        progress(1, 4)
        raise KeyboardInterrupt

    monkeypatch.setattr(check_command, "run_check", interrupted)
    code, _, _ = run(capsys, recording, *QUICK, "--datasets", 2, "--out", tmp_path / "new")
    assert code == 1 and not (tmp_path / "new" / "check.csv").exists()
    (tmp_path / "check.csv").write_text("earlier\n")
    code, _, _ = run(capsys, recording, *QUICK, "--datasets", 2, "--out", tmp_path)
    assert code == 1 and (tmp_path / "check.csv").read_text() == "earlier\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["check.csv"]  # no temporary left beside it


def test_a_recording_under_the_name_is_never_replaced(recording, tmp_path, capsys):
    (tmp_path / "check.csv").write_bytes(recording.read_bytes())
    code, _, err = run(capsys, recording, *QUICK, "--datasets", 2, "--players", "", "--out", tmp_path)
    assert code == 2 and "is a recording" in err


def test_one_worker_and_a_local_cluster_of_two_write_the_same_check_csv(recording, tmp_path, capsys,
                                                                        no_dask_thread_left_behind):
    common = [recording, *QUICK, "--datasets", 3, "--players", "loose", "--seed", 5]
    code, out, _ = run(capsys, *common, "--workers", 1, "--out", tmp_path / "one")
    assert code == 0 and "boltzmann: " in out
    code, _, err = run(capsys, *common, "--scheduler", "local:2", "--out", tmp_path / "cluster")
    assert code == 0, err
    one = (tmp_path / "one" / "check.csv").read_text()
    assert one == (tmp_path / "cluster" / "check.csv").read_text()
    lines = one.splitlines()
    assert lines[0] == ",".join(CSV_COLUMNS)
    assert [line.split(",")[:3] for line in lines[1:]] == [
        ["boltzmann", "false", "U"], ["boltzmann", "false", "C"], ["boltzmann", "false", "G"],
        ["loose", "true", "U"], ["loose", "true", "C"], ["loose", "true", "G"]]
    assert all(line.split(",")[3] == "3" for line in lines[1:])
    code, _, _ = run(capsys, *common, "--workers", 1, "--seed", 6, "--out", tmp_path / "other")
    assert (tmp_path / "other" / "check.csv").read_text() != one


def test_a_check_writes_its_calibration_and_a_fit_widens_by_it_or_refuses_it_naming_the_field(
        recording, tmp_path, capsys):
    code, out, err = run(capsys, recording, *QUICK, "--datasets", 3, "--players", "hasty", "--workers", 1,
                         "--out", tmp_path)
    assert code == 0, err
    learned = json.loads((tmp_path / "calibration.json").read_text())
    assert learned["players"] == ["boltzmann", "hasty"] and set(learned["scales"]) == {"U", "C", "G"}
    assert learned["datasets"] == 3 and learned["world"] == "mud" and learned["options"]["tie"] is True
    assert "calibration: half-widths around the point widened" in out
    plain, calibrated = tmp_path / "plain.json", tmp_path / "calibrated.json"
    assert main(["fit", str(recording), *QUICK, "--intervals", "--no-view", "--json", str(plain)]) == 0
    assert main(["fit", str(recording), *QUICK, "--intervals", "--no-view", "--json", str(calibrated),
                 "--calibration", str(tmp_path / "calibration.json")]) == 0
    plain_fit, calibrated_fit = json.loads(plain.read_text()), json.loads(calibrated.read_text())
    assert plain_fit["interval_method"] == "bootstrap"
    assert calibrated_fit["interval_method"] == "bootstrap+calibrated" and "calibrated" in calibrated_fit["note_codes"]
    for row, wide_row in zip(plain_fit["interval"], calibrated_fit["interval"]):
        for cell, wide in zip(row, wide_row):
            if cell is not None:
                assert wide[0] <= cell[0] and cell[1] <= wide[1]
    capsys.readouterr()
    code = main(["fit", str(recording), "--method", "maxent", "--beta", "1", "--resamples", "20", "--intervals",
                 "--no-view", "--calibration", str(tmp_path / "calibration.json")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "calibration.json: options.tie: learned with true" in err
    # A check of the calibrated fit measures it and learns nothing new: the calibration stays as it was.
    before = (tmp_path / "calibration.json").read_text()
    code, out, err = run(capsys, recording, *QUICK, "--datasets", 2, "--players", "", "--workers", 1,
                         "--calibration", tmp_path / "calibration.json", "--out", tmp_path)
    assert code == 0, err
    assert "no new calibration" in out and (tmp_path / "calibration.json").read_text() == before
