"""A study that holds reach worlds (docs/studies.md, docs/reach.md): read, counted from the participant's reach
recordings, and refused in one line by the commands that take grid worlds only."""

from __future__ import annotations

import pytest

from careful_tui.cli import main
from irl_core.errors import StudyError
from irl_core.play.reach_session import ReachOptions, ReachSession, reach_header
from irl_core.players.experts import SIMULATED_AT
from irl_core.recordings.lines import StudyTag
from irl_core.recordings.writer import SessionRecorder
from irl_core.studies.study import load_study, read_protocol
from irl_core.worlds.reach import REACH_WORLDS
from irl_core.worlds.world import BUILTIN_WORLDS


def write_study(folder, body: str):
    path = folder / "study.toml"
    path.write_text('name = "mixed"\nout = "data"\n' + body)
    return path


def test_a_study_reads_built_in_and_file_reach_worlds_beside_grid_ones(tmp_path):
    (tmp_path / "own.toml").write_text(REACH_WORLDS["reach"].model_copy(update={"noise": "own", "name": "own"}).to_toml())
    study = load_study(write_study(tmp_path, 'worlds = ["paper", "reach-mild", "own.toml"]\n'))
    assert study.worlds[0] == BUILTIN_WORLDS["paper"] and study.worlds[1] == REACH_WORLDS["reach-mild"]
    assert study.worlds[2].noise == "own" and study.study.calibration_reaches == 10
    with pytest.raises(StudyError, match="worlds\\[1\\]: this command does not take reach worlds"):
        _ = study.grid_worlds


def test_a_level_calibration_block_cannot_come_before_a_reach_world(tmp_path):
    with pytest.raises(StudyError, match="calibration_block: worlds\\[0\\] is a reach world that comes first"):
        load_study(write_study(tmp_path, 'worlds = ["reach", "paper"]\ncalibration_block = 4\n'))


def test_the_protocol_counts_each_recorded_reach_as_a_done_episode(tmp_path):
    study = load_study(write_study(tmp_path, 'worlds = ["reach"]\npractice_episodes = 1\nepisodes = 3\n'))
    protocol = read_protocol(study, "p1")
    block = protocol.next_block
    assert (block.phase, block.target, block.done) == ("practice", 1, 0)
    header = reach_header(study.worlds[0], player="p1", seed=0, app_version="t").model_copy(update={
        "study": StudyTag(name="mixed", participant="p1", phase="main", world_index=0), "created": SIMULATED_AT})
    session = ReachSession(study.worlds[0], SessionRecorder(study.participant_folder("p1"), header), seed=0,
                           options=ReachOptions(trials=2))
    for _ in range(2):
        session.press("space", at=0.0)
        session.release("space", at=0.5)
    session.quit()
    blocks = read_protocol(study, "p1").blocks
    assert [(b.phase, b.done, b.target) for b in blocks] == [("practice", 0, 1), ("main", 2, 3)]
    assert read_protocol(study, "p1").progress == (2, 4)


@pytest.mark.parametrize("command", [["study", "report"], ["study", "plan"], ["study", "run"]])
def test_the_grid_commands_refuse_a_reach_study_in_one_line(tmp_path, capsys, command):
    path = write_study(tmp_path, 'worlds = ["paper", "reach"]\n')
    extra = ["--participant", "p1"] if command[-1] == "run" else []
    assert main([*command, str(path), *extra]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "worlds[1]" in error and "does not take reach worlds" in error
    assert not (tmp_path / "data").exists()
