"""One reader error type (`irl_core.errors.InputError`) for every file problem, caught by every caller.

Before: an episode number of 2^63 or a number of 5,000 digits gave "unexpected error", exit 1, in
`fit` and `export`, and (the study readers catching only their own error) stopped `study report`
for everyone, blocked `study run` for that participant and ended `experiment --recordings`; a lone
surrogate in a name (CSV export), a 5,000-digit integer in a study file, a world reference longer
than the system's name limit or holding NUL were exit 1 too; 40,000 world references took 113 s
and 1.8 GB before any check; `/proc/kmsg` as an input blocked forever.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from hardening_checks import assert_refused, careful, recording

from irl_core.errors import InputError, StudyError, WorldError
from irl_core.experiment.run import human_sessions
from irl_core.studies import study as study_module
from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study, read_protocol
from irl_core.worlds.world import BUILTIN_WORLDS, load_world


def spoiled(path: Path, how: str) -> Path:
    """`path` (a recording) with one field made hostile; returns the path."""
    lines = path.read_text().splitlines()
    header, step, end = json.loads(lines[0]), lines[1], next(i for i, l in enumerate(lines) if "episode_end" in l)
    if how == "episode 2^63":
        lines[1] = step.replace('"episode": 0', f'"episode": {2**63}')
    elif how == "episode 2^53 + 1":
        lines[1] = step.replace('"episode": 0', f'"episode": {2**53 + 1}')
    elif how == "t of 5,000 digits":
        lines[1] = step.replace('"t": 0', '"t": ' + "7" * 5000)
    elif how == "seed of 5,000 digits":
        lines[0] = re.sub(r'"seed": \d+', '"seed": ' + "3" * 5000, lines[0])
    elif how == "surrogate in player":
        header["player"] = "p\ud800"
        lines[0] = json.dumps(header)
    elif how == "surrogate in world name":
        header["world"]["name"] = "\udfffw"
        lines[0] = json.dumps(header)
    elif how == "surrogate in terminal_symbol":
        lines[end] = lines[end].replace('"terminal_symbol": "G"', '"terminal_symbol": "\\udc00"').replace(
            '"terminal_symbol": "C"', '"terminal_symbol": "\\udc00"')
    else:
        raise AssertionError(how)
    path.write_text("\n".join(lines) + "\n")
    return path


HOSTILE = ["episode 2^63", "episode 2^53 + 1", "t of 5,000 digits", "seed of 5,000 digits", "surrogate in player",
           "surrogate in world name", "surrogate in terminal_symbol"]


@pytest.mark.parametrize("how", HOSTILE)
@pytest.mark.parametrize("command", ["fit", "export"])
def test_a_hostile_number_or_name_is_one_line_and_exit_2(tmp_path, capsys, how, command):
    bad = spoiled(recording(tmp_path / "bad.jsonl", episodes=2), how)
    args = [bad, "--no-view"] if command == "fit" else [bad, "--format", "csv", "--out", tmp_path / "out.csv"]
    assert_refused(*careful(capsys, command, *args), "bad.jsonl:")
    assert not (tmp_path / "out.csv").exists()


def study_with_participants(tmp_path: Path, count: int = 3) -> Path:
    study = tmp_path / "s.toml"
    study.write_text('worlds = ["paper"]\nepisodes = 3\npractice_episodes = 0\n')
    loaded = load_study(study)
    for who in simulated_participants(count):
        write_simulated_participant(loaded, who)
    return study


@pytest.mark.parametrize("how", ["episode 2^63", "t of 5,000 digits", "surrogate in player"])
def test_one_bad_file_never_stops_the_study_report_for_the_others(tmp_path, capsys, how):
    study = study_with_participants(tmp_path)
    (bad,) = (tmp_path / "data" / "sim01").glob("*.jsonl")
    spoiled(bad, how)
    status, out, err = careful(capsys, "study", "report", study, "--resamples", "20", "--workers", "1")
    assert status == 0, err
    assert "sim01" in err and "left out" in err and "Traceback" not in err
    assert "sim02" in out and "sim03" in out


@pytest.mark.parametrize("how", ["episode 2^63", "seed of 5,000 digits"])
def test_one_bad_file_never_blocks_study_run_for_its_participant(tmp_path, how):
    study = study_with_participants(tmp_path, 1)
    (bad,) = (tmp_path / "data" / "sim01").glob("*.jsonl")
    spoiled(bad, how)
    protocol = read_protocol(load_study(study), "sim01")
    assert any("bad" in p or bad.name in p for p in protocol.problems) and not protocol.finished


def test_one_bad_file_never_ends_experiment_recordings(tmp_path):
    folder = tmp_path / "people"
    folder.mkdir()
    good = recording(folder / "a-good.jsonl", episodes=2)
    text = good.read_text().replace('"expert:optimal"', '"ann"')
    good.write_text(text)
    (folder / "b-bad.jsonl").write_text(text)
    spoiled(folder / "b-bad.jsonl", "episode 2^63")
    found, left_out = human_sessions(folder, BUILTIN_WORLDS["paper"])
    assert found == [good] and len(left_out) == 1 and "b-bad.jsonl:2: episode" in left_out[0]


@pytest.mark.parametrize("field", ["episodes", "practice_episodes"])
def test_a_5000_digit_integer_in_a_study_file_is_one_line(tmp_path, capsys, field):
    study = tmp_path / "s.toml"
    study.write_text(f'worlds = ["paper"]\n{field} = {"9" * 5000}\n')
    assert_refused(*careful(capsys, "study", "report", study), "s.toml", "4,300 digits")


def test_a_5000_digit_integer_in_a_world_file_is_one_line(tmp_path, capsys):
    world = tmp_path / "w.toml"
    world.write_text(f'layout = """\n...\n.CG\n"""\nlevels = {"1" * 5000}\n')
    assert_refused(*careful(capsys, "worlds", "--show", world), "w.toml", "4,300 digits")


@pytest.mark.parametrize(("reference", "said"), [
    ("w" * 300 + ".toml", "over the system's"),
    ("sub/" + "x" * 256, "over the system's"),
    ("a\x00b.toml", "NUL"),
    ("/".join(["é"] * 1400), "4,096 bytes"),  # 2,799 characters, 4,199 bytes
], ids=["long name", "long name in a folder", "NUL", "long path"])
def test_a_world_reference_no_system_can_open_is_one_line(tmp_path, capsys, reference, said):
    study = tmp_path / "s.toml"
    study.write_text("worlds = [" + json.dumps(reference) + "]\n")
    assert_refused(*careful(capsys, "study", "report", study), "worlds[0]", said)
    with pytest.raises(WorldError, match=said):
        load_world(reference)


def test_40000_world_references_are_refused_before_any_is_read(tmp_path, monkeypatch):
    reads = []
    monkeypatch.setattr(study_module, "load_world", lambda source: reads.append(source) or BUILTIN_WORLDS["paper"])
    study = tmp_path / "s.toml"
    study.write_text("worlds = [" + ", ".join(['"paper"'] * 40_000) + "]\n")
    with pytest.raises(StudyError, match="at most 1000"):
        load_study(study)
    assert reads == []


def test_a_world_named_twice_is_read_once(tmp_path, monkeypatch):
    reads = []
    real = study_module.load_world
    monkeypatch.setattr(study_module, "load_world", lambda source: reads.append(source) or real(source))
    world = tmp_path / "w.toml"
    world.write_text('layout = """\n...\n.CG\n"""\nlevels = 3\n')
    study = tmp_path / "s.toml"
    study.write_text('worlds = ["w.toml", "w.toml", "paper", "w.toml"]\n')
    assert len(load_study(study).worlds) == 4 and len(reads) == 2


def test_every_reader_error_is_one_type():
    from irl_core.errors import RecordingError

    assert all(issubclass(error, InputError) for error in (RecordingError, WorldError, StudyError))


KMSG = Path("/proc/kmsg")


@pytest.mark.skipif(not os.access(KMSG, os.R_OK), reason="needs a readable /proc/kmsg")
@pytest.mark.parametrize("command", [["fit", str(KMSG), "--no-view"], ["worlds", "--show", str(KMSG)],
                                     ["study", "report", str(KMSG)]])
def test_a_file_that_would_block_is_refused_not_waited_on(command):
    # Before, these waited forever; the timeout only stops a regression from hanging the suite.
    done = subprocess.run([sys.executable, "-m", "careful_tui.cli", *command], capture_output=True, text=True,
                          timeout=120, env=os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)})
    assert_refused(done.returncode, done.stdout, done.stderr)
