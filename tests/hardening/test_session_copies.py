"""A session is counted once in the study readers however many copies its participant's folder holds.

Before, a backup copy of a recording in a participant's folder (its own inode) counted twice: a
block read as finished, and the report fitted the same episodes twice.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from hardening_checks import careful

from irl_core.studies.simulated import simulated_participants, write_simulated_participant
from irl_core.studies.study import load_study, read_participant, read_protocol


@pytest.fixture
def study(tmp_path: Path) -> Path:
    path = tmp_path / "s.toml"
    path.write_text('worlds = ["paper"]\nepisodes = 4\npractice_episodes = 0\n')
    return path


def half_played(study: Path) -> Path:
    """sim01's recording of 4 main episodes, cut to its first 2 (a participant who left)."""
    (path,) = write_simulated_participant(load_study(study), simulated_participants(1)[0])
    lines = path.read_text().splitlines(keepends=True)
    second_end = [i for i, line in enumerate(lines) if '"episode_end"' in line][1]
    path.write_text("".join(lines[: second_end + 1]))
    return path


@pytest.mark.parametrize("copy", ["same bytes", "an earlier backup", "a hard link"])
def test_a_copy_of_a_session_counts_once_and_is_named(study, copy):
    path = half_played(study)
    backup = path.with_name("backup-" + path.name)
    if copy == "a hard link":
        backup.hardlink_to(path)
    else:
        shutil.copy(path, backup)
    if copy == "an earlier backup":  # taken after the first episode: the original holds all of it and more
        lines = backup.read_text().splitlines(keepends=True)
        first_end = next(i for i, line in enumerate(lines) if '"episode_end"' in line)
        backup.write_text("".join(lines[: first_end + 1]))
    loaded = load_study(study)
    protocol = read_protocol(loaded, "sim01")
    (block,) = protocol.blocks
    assert block.done == 2 and block.remaining == 2 and block.next_episode == 2
    found = read_participant(loaded, "sim01")
    (kept,) = [r.path for _, r in found.recordings]
    assert found.left_out == 1 and kept == (path if copy == "an earlier backup" else min(path, backup))
    (said,) = [p for p in found.problems if "copy of the session" in p]
    left = backup if kept == path else path
    assert said.startswith(str(left)) and kept.name in said


def test_the_report_fits_a_copied_session_once(study, capsys):
    path = half_played(study)
    shutil.copy(path, path.with_name("zz-copy.jsonl"))
    status, out, err = careful(capsys, "study", "report", study, "--resamples", "20", "--workers", "1")
    assert status == 0, err
    assert "zz-copy.jsonl: a copy of the session" in err
    row = next(line for line in out.splitlines() if line.strip().startswith("sim01"))
    assert " 2 " in row  # 2 episodes, not 4


def test_two_sessions_with_different_headers_both_count(study):
    path = half_played(study)
    other = path.with_name("other.jsonl")
    other.write_text(re.sub(r'"seed": \d+', '"seed": 12345', path.read_text(), count=1))
    loaded = load_study(study)
    assert len(read_participant(loaded, "sim01").recordings) == 2
