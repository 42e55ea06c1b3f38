"""No command overwrites a file it reads or a recording; a write that fails is one line, exit 2.

Every case runs the real command and checks the exit status, the one line on stderr, that no
input changed, and that no control character reached the output (`hardening_checks`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hardening_checks import assert_refused, careful, digest, fill, recording, tiny_filesystem

from irl_core.errors import OutputError
from irl_core.support.safe_files import check_output, is_recording, write_output


@pytest.fixture
def rec(tmp_path: Path) -> Path:
    return recording(tmp_path / "a.jsonl")


@pytest.mark.parametrize("option", ["--json", "--svg"])
def test_fit_refuses_to_write_over_the_recording_it_reads(tmp_path, capsys, rec, option):
    before = digest(rec)
    assert_refused(*careful(capsys, "fit", rec, "--no-view", option, rec), option, "a file this command reads")
    assert digest(rec) == before


@pytest.mark.parametrize("link", ["symlink", "hardlink"])
def test_fit_sees_through_links_to_its_input(tmp_path, capsys, rec, link):
    out = tmp_path / "out.json"
    (out.symlink_to if link == "symlink" else out.hardlink_to)(rec)
    before = digest(rec)
    assert_refused(*careful(capsys, "fit", rec, "--no-view", "--json", out), "a file this command reads")
    assert digest(rec) == before


def test_fit_refuses_to_write_over_another_recording(tmp_path, capsys, rec):
    other = recording(tmp_path / "b.jsonl", seed=1)
    before = digest(rec, other)
    assert_refused(*careful(capsys, "fit", rec, "--no-view", "--json", other), "is a recording", "never overwritten")
    assert digest(rec, other) == before


def test_fit_replaces_its_own_earlier_json(tmp_path, capsys, rec):
    out = tmp_path / "fit.json"
    out.write_text("{}")
    status, _, err = careful(capsys, "fit", rec, "--no-view", "--json", out)
    assert status == 0, err
    assert json.loads(out.read_text())["method"] == "lp"


@pytest.mark.parametrize(("target", "problem"), [
    ("missing/out.json", "does not exist"),
    ("folder", "is a folder"),
    ("fifo", "FIFO"),
])
def test_fit_output_that_cannot_be_a_file(tmp_path, capsys, rec, target, problem):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    assert_refused(*careful(capsys, "fit", rec, "--no-view", "--json", tmp_path / target), "--json", problem)


def test_simulate_refuses_an_existing_recording_and_its_own_world_file(tmp_path, capsys, rec):
    world = tmp_path / "w.toml"
    world.write_text('layout = """\n...\n.CG\n"""\n')
    before = digest(rec, world)
    base = ["simulate", "--policy", "optimal", "--episodes", "2", "--seed", "0"]
    assert_refused(*careful(capsys, *base, "--world", "paper", "--out", rec), "--out", "never overwritten")
    assert_refused(*careful(capsys, *base, "--world", world, "--out", world), "--out", "a file this command reads")
    assert digest(rec, world) == before


@pytest.mark.parametrize(("out", "problem"), [
    ("/proc/careful-test.jsonl", "cannot write the recording"),
    ("x" * 300 + ".jsonl", "File name too long"),
])
def test_simulate_to_a_path_that_cannot_be_written(tmp_path, capsys, out, problem):
    path = out if out.startswith("/") else tmp_path / out
    assert_refused(*careful(capsys, "simulate", "--world", "paper", "--policy", "optimal", "--episodes", "2",
                            "--seed", "0", "--out", path), "--out", problem)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("disk", ["full", "read-only"])
def test_simulate_on_a_full_or_read_only_disk_leaves_nothing(tmp_path, capsys, disk):
    with tiny_filesystem(tmp_path / "disk", read_only=disk == "read-only") as folder:
        if disk == "full":
            fill(folder)
        before = digest(folder)
        line = assert_refused(*careful(capsys, "simulate", "--world", "paper", "--policy", "optimal",
                                       "--episodes", "300", "--seed", "0", "--out", folder / "x.jsonl"), "--out")
        assert ("No space left" in line) if disk == "full" else ("Read-only" in line)
        assert digest(folder) == before  # no empty or partial recording left behind


def test_fit_json_on_a_full_disk_keeps_the_old_file_whole(tmp_path, capsys, rec):
    with tiny_filesystem(tmp_path / "disk") as folder:
        out = folder / "fit.json"
        out.write_text('{"old": true}')
        fill(folder)
        assert_refused(*careful(capsys, "fit", rec, "--no-view", "--json", out), "--json", "No space left")
        assert out.read_text() == '{"old": true}'
        assert sorted(p.name for p in folder.iterdir()) == ["filler", "fit.json"]


def test_experiment_refuses_a_fifo_as_its_folder(tmp_path, capsys):
    os.mkfifo(tmp_path / "fifo")
    assert_refused(*careful(capsys, "experiment", "--quick", "--out", tmp_path / "fifo"), "--out", "FIFO")


def test_the_guard_itself(tmp_path, rec):
    assert is_recording(rec) and not is_recording(tmp_path / "missing")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    with pytest.raises(OutputError, match="link to nothing"):
        check_output(tmp_path / "dangling", option="--json")
    assert not (tmp_path / "nowhere").exists()
    out = write_output(tmp_path / "new.txt", "text", option="--json", inputs=[rec])
    assert out.read_text() == "text" and oct(out.stat().st_mode & 0o777) != "0o600"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.jsonl", "dangling", "new.txt"]


@pytest.mark.parametrize(("target", "problem"), [("a.jsonl", "a file this command reads"),
                                                 ("b.jsonl", "is a recording"), ("fifo", "FIFO")])
def test_export_refuses_inputs_recordings_and_fifos(tmp_path, capsys, rec, target, problem):
    other = recording(tmp_path / "b.jsonl", seed=1)
    os.mkfifo(tmp_path / "fifo")
    before = digest(rec, other)
    assert_refused(*careful(capsys, "export", rec, "--format", "csv", "--out", tmp_path / target), "--out", problem)
    assert digest(rec, other) == before
