"""Every output is built beside its name and renamed in whole; every file a command reads is guarded; CSV cells are never formulas.

Before: SIGKILL during CSV export or `simulate` left a shorter file under the final name that read
as complete; SIGKILL during a Minari export left a dataset of some of the episodes; two Minari
exports to one id raced and the loser deleted the winner's dataset; an id nested in a dataset was
written inside it; `fit --json` replaced a recording whose first 64 KB were blank lines or whose
header put `kind` late; `study report` replaced a world file it read; export's and the report's
CSV wrote names starting with `=`, `+`, `-`, `@` as they were.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hardening_checks import assert_refused, careful, digest, recording

from irl_core.recordings import export as export_module
from irl_core.recordings.demonstrations import read_recording
from irl_core.support.csv_cells import text_cell
from irl_core.support.safe_files import is_recording

ENV = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}


def kill_when(command: list[str], appears, *, folder: Path, env=ENV) -> None:
    """Start `careful COMMAND`, SIGKILL it as soon as `appears(folder)` is true (its output is being built)."""
    process = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", *command], env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 120
        while time.monotonic() < end and process.poll() is None and not appears(folder):
            time.sleep(0.005)
        assert process.poll() is None, "the command finished before it could be killed: make it bigger"
        process.send_signal(signal.SIGKILL)
    finally:
        process.wait(timeout=60)


def building(folder: Path) -> bool:
    return any(p.name.endswith(".part") for p in folder.iterdir())


def test_csv_export_killed_mid_write_leaves_no_file_under_its_name(tmp_path):
    big = recording(tmp_path / "big.jsonl", world="mud", episodes=20_000)
    out = tmp_path / "out" / "steps.csv"
    out.parent.mkdir()
    kill_when(["export", str(big), "--format", "csv", "--out", str(out)], building, folder=out.parent)
    assert not out.exists()


def test_simulate_killed_mid_write_leaves_no_recording_under_its_name(tmp_path):
    out = tmp_path / "out" / "expert.jsonl"
    out.parent.mkdir()
    kill_when(["simulate", "--world", "mud", "--policy", "optimal", "--episodes", "2000000", "--seed", "1",
               "--out", str(out)], building, folder=out.parent)
    assert not out.exists()


@pytest.fixture
def datasets(tmp_path, monkeypatch):
    root = tmp_path / "minari"
    root.mkdir()
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    return root


def test_minari_export_killed_mid_build_leaves_no_dataset(tmp_path, datasets):
    import minari

    big = recording(tmp_path / "big.jsonl", world="mud", episodes=20_000)
    hidden = lambda root: any(p.name.startswith(".") for p in root.iterdir())  # noqa: E731
    kill_when(["export", str(big), "--format", "minari", "--out", "careful/big-v0"], hidden, folder=datasets,
              env=ENV | {"MINARI_DATASETS_PATH": str(datasets)})
    assert "careful/big-v0" not in minari.list_local_datasets()
    assert not (datasets / "careful" / "big-v0").exists()


def test_two_minari_exports_to_one_id_never_delete_each_others_dataset(tmp_path, datasets, monkeypatch):
    import minari

    first = recording(tmp_path / "a.jsonl", episodes=6, seed=1)
    second = recording(tmp_path / "b.jsonl", episodes=3, seed=2)
    monkeypatch.setattr(export_module, "MINARI_BATCH", 2)
    raced = []

    def meanwhile(done: int) -> None:  # while the first is built, a second export (a process of its own) takes the id
        if not raced:
            raced.append(subprocess.run([sys.executable, "-m", "careful_tui.cli", "export", str(second), "--format",
                                         "minari", "--out", "careful/race-v0"], capture_output=True, text=True,
                                        env=ENV | {"MINARI_DATASETS_PATH": str(datasets)}))
            assert raced[0].returncode == 0, raced[0].stderr

    with pytest.raises(FileExistsError, match="while this one was built"):
        export_module.write_minari("careful/race-v0", [read_recording(first)], description="a", progress=meanwhile)
    kept = minari.load_dataset("careful/race-v0")
    assert kept.total_episodes == 3 and kept.total_steps == len(read_recording(second).steps)
    assert [p.name for p in datasets.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("nested", ["careful/outer-v0/inner-v0", "careful/outer-v0/deeper/inner-v1"])
def test_a_dataset_id_inside_another_dataset_is_refused(tmp_path, datasets, capsys, nested):
    rec = recording(tmp_path / "a.jsonl", episodes=2)
    status, _, err = careful(capsys, "export", rec, "--format", "minari", "--out", "careful/outer-v0")
    assert status == 0, err
    before = digest(datasets / "careful" / "outer-v0")
    assert_refused(*careful(capsys, "export", rec, "--format", "minari", "--out", nested),
                   "inside the Minari dataset 'careful/outer-v0'")
    assert digest(datasets / "careful" / "outer-v0") == before


@pytest.mark.parametrize("shape", ["blank lines", "crlf blank lines", "kind late"])
def test_fit_json_never_replaces_a_recording_however_its_header_starts(tmp_path, capsys, shape):
    rec = recording(tmp_path / "a.jsonl", episodes=2)
    lines = rec.read_text().splitlines()
    header = json.loads(lines[0])
    target = tmp_path / "b.jsonl"
    if shape == "kind late":
        header["app_version"] = "x" * 70_000  # kind after the first 64 KB
        moved = {k: v for k, v in header.items() if k != "kind"} | {"kind": "session"}
        target.write_text("\n".join([json.dumps(moved), *lines[1:]]) + "\n")
    else:
        blank = "\n" if shape == "blank lines" else " \r\n"
        target.write_text(blank * 70_000 + "\n".join(lines) + "\n")
    assert read_recording(target).header.kind == "session"  # the reader reads it: it is a recording
    assert is_recording(target)
    before = digest(target)
    assert_refused(*careful(capsys, "fit", rec, "--no-view", "--json", target), "is a recording")
    assert digest(target) == before


def test_study_report_never_replaces_a_world_file_it_reads(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    world = out / "report.csv"  # a world file whose name the report would write
    world.write_text('name = "w"\nlayout = """\n....\n.CCG\n"""\nlevels = 3\n[rewards]\nC = -100.0\nG = 10.0\n')
    study = tmp_path / "s.toml"
    study.write_text('worlds = ["out/report.csv"]\nepisodes = 2\npractice_episodes = 0\n')
    from irl_core.studies.simulated import simulated_participants, write_simulated_participant
    from irl_core.studies.study import load_study

    write_simulated_participant(load_study(study), simulated_participants(1)[0])
    before = digest(world)
    assert_refused(*careful(capsys, "study", "report", study, "--out", out, "--resamples", "20", "--workers", "1"),
                   "a file this command reads")
    assert digest(world) == before


@pytest.mark.parametrize("value", ["=HYPERLINK(\"http://x\")", "+1+1", "-2+3", "@SUM(A1)", "\tx", "\rx"])
def test_text_cell_makes_every_formula_start_text(value):
    assert text_cell(value) == "'" + value and text_cell("plain") == "plain"


def test_export_csv_writes_formula_names_as_text(tmp_path, capsys):
    rec = recording(tmp_path / "a.jsonl", episodes=1)
    lines = rec.read_text().splitlines()
    header = json.loads(lines[0])
    header["player"] = "=cmd|' /C calc'!A0"
    (tmp_path / "=b.jsonl").write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    out = tmp_path / "out.csv"
    status, _, err = careful(capsys, "export", tmp_path / "=b.jsonl", "--format", "csv", "--out", out)
    assert status == 0, err
    rows = list(csv.DictReader(out.open(newline="")))
    assert rows and all(row["player"] == "'=cmd|' /C calc'!A0" for row in rows)
    assert all(not row["file"].startswith(("=", "+", "-", "@")) for row in rows)
    assert float(rows[0]["reward"]) < 0 or rows[0]["reward"][0] != "'"  # numbers stay numbers


def test_study_report_csv_writes_formula_names_as_text(tmp_path, capsys):
    world = tmp_path / "w.toml"
    world.write_text('name = "@SUM(1+1)"\nlayout = """\n....\n.CCG\n"""\nlevels = 3\n[rewards]\nC = -100.0\nG = 10.0\n')
    study = tmp_path / "s.toml"
    study.write_text('name = "-study"\nworlds = ["w.toml"]\nepisodes = 2\npractice_episodes = 0\n')
    from irl_core.studies.simulated import simulated_participants, write_simulated_participant
    from irl_core.studies.study import load_study

    write_simulated_participant(load_study(study), simulated_participants(1)[0])
    status, _, err = careful(capsys, "study", "report", study, "--resamples", "20", "--workers", "1")
    assert status == 0, err
    rows = list(csv.DictReader((tmp_path / "data" / "report" / "report.csv").open(newline="")))
    assert {row["world"] for row in rows} == {"'@SUM(1+1)"} and {row["study"] for row in rows} == {"'-study"}
