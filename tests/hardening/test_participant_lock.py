"""One session per participant at a time (`irl_core.studies.participant_lock`), for `study run` and a web server.

Before, two `study run` for one participant at once played the same block under the same episode
numbers (4 of 2 episodes done, each number twice, all fitted).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hardening_checks import assert_refused, careful

from irl_core.errors import ParticipantBusy
from irl_core.studies.participant_lock import participant_lock
from irl_core.studies.report import participant_ids
from irl_core.studies.study import load_study

HOLD = """
import sys, time
from irl_core.studies.participant_lock import participant_lock
from irl_core.studies.study import load_study
with participant_lock(load_study(sys.argv[1]), sys.argv[2], holder="browser session 3f2a"):
    print("held", flush=True)
    time.sleep(600)
"""


@pytest.fixture
def study(tmp_path: Path) -> Path:
    path = tmp_path / "s.toml"
    path.write_text('worlds = ["paper"]\nepisodes = 2\n')
    return path


def holding(study: Path, participant: str) -> subprocess.Popen:
    process = subprocess.Popen([sys.executable, "-c", HOLD, str(study), participant], stdout=subprocess.PIPE, text=True,
                               env=os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)})
    assert process.stdout.readline().strip() == "held"
    return process


def test_a_second_study_run_is_told_who_holds_the_participant(study, capsys):
    holder = holding(study, "p07")
    try:
        line = assert_refused(*careful(capsys, "study", "run", study, "--participant", "p07"),
                              "participant p07 is in another session already", "browser session 3f2a",
                              f"process {holder.pid}")
        assert "let that one finish" in line
    finally:
        holder.kill()
        holder.wait()


def test_in_one_process_too_the_second_holder_is_refused_and_others_are_free(study):
    loaded = load_study(study)
    with participant_lock(loaded, "p01", holder="the web server, session a"):
        with pytest.raises(ParticipantBusy) as caught:
            with participant_lock(loaded, "p01", holder="the web server, session b"):
                pass
        assert "session a" in caught.value.holder and caught.value.participant == "p01"
        with participant_lock(loaded, "p02", holder="session c"):  # another participant is not blocked
            pass
    with participant_lock(loaded, "p01", holder="session b"):  # released at the end of the block
        pass


def test_a_killed_holder_never_locks_the_participant_out(study):
    holder = holding(study, "p03")
    holder.send_signal(signal.SIGKILL)
    holder.wait()
    with participant_lock(load_study(study), "p03", holder="next"):
        pass


def test_the_lock_is_not_a_participant_folder(study):
    loaded = load_study(study)
    with participant_lock(loaded, "p04", holder="x"):
        assert participant_ids(loaded) == ([], [])
