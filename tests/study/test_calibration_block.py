"""A study's motor calibration block (``calibration_block = N``), played headless through the flow:
the trial lines land in the participant's first file, a participant who leaves mid-block is asked
only the rest, practice follows, and every reader of recordings takes the file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from play_fixtures import FakeClock

from irl_core.errors import RecordingError, StudyError
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.recordings.export import write_csv
from irl_core.studies.flow import StudyFlow
from irl_core.studies.study import load_study, read_protocol

STUDY = """\
name = "motor"
worlds = ["mud"]
practice_episodes = 1
episodes = 1
calibration_block = {n}
input = "hold"
out = "data"
"""


def study_file(folder: Path, n: int = 4) -> Path:
    path = folder / "motor.toml"
    path.write_text(STUDY.format(n=n))
    return path


def hold_to(block, clock: FakeClock, level: int) -> None:
    """Hold an arrow (its release timed, as a browser or kitty does) for the middle of `level`'s window."""
    p = block.profile
    ms = p.tap_ms / 2 if level == 1 else p.tap_ms + (level - 1.5) * p.ms_per_level
    block.press("up", at=clock(), repeat=False)
    clock.advance(ms / 1000)
    block.release("up", at=clock())


def test_trials_are_recorded_in_the_first_file_and_practice_follows(tmp_path: Path) -> None:
    clock = FakeClock()
    flow = StudyFlow(load_study(study_file(tmp_path)), "p01", clock=clock, seed=3, app_version="test")
    block = flow.calibration()
    assert block is not None and flow.stage == "calibration"
    asked = []
    while not block.view().done:
        target = block.view().target
        assert target is not None and str(target) in block.view().instruction
        asked.append(target)
        hold_to(block, clock, target - 1)  # an under-holder: one level short each time
    flow.calibration_ended()
    assert flow.calibration() is None, "the block is not asked twice"
    following = flow.protocol.next_block
    assert following is not None and following.phase == "practice" and following.done == 0
    assert flow.next_block() is not None
    flow.quit()
    files = sorted((tmp_path / "data" / "p01").glob("*.jsonl"))
    assert len(files) == 1, "no practice move was made, so the trials' file is the only one"
    lines = [json.loads(line) for line in files[0].read_text().splitlines()]
    assert lines[0]["study"]["phase"] == "practice"
    trials = lines[1:]
    assert [t["kind"] for t in trials] == ["calibration_trial"] * 4
    assert [t["target"] for t in trials] == asked
    assert [t["produced"] for t in trials] == [c - 1 for c in asked]
    assert all(t["hold_exact"] is True for t in trials)
    recording = read_recording(files[0])
    assert [(t.target, t.produced) for t in recording.calibration_trials] == [(c, c - 1) for c in asked]
    assert len(recording.steps) == 0


def test_a_participant_who_left_mid_block_is_asked_the_rest(tmp_path: Path) -> None:
    path = study_file(tmp_path, n=5)
    clock = FakeClock()
    flow = StudyFlow(load_study(path), "p02", clock=clock, seed=1, app_version="test")
    block = flow.calibration()
    assert block is not None
    for _ in range(2):
        hold_to(block, clock, block.view().target or 1)
    flow.quit()
    again = StudyFlow(load_study(path), "p02", clock=clock, seed=1, app_version="test")
    assert again.protocol.calibration_trials == 2
    rest = again.calibration()
    assert rest is not None and len(rest.targets) == 3 and rest.view().number == 3 and rest.view().count == 5
    while not rest.view().done:
        hold_to(rest, clock, rest.view().target or 1)
    again.calibration_ended()
    assert read_protocol(load_study(path), "p02").calibration_trials == 5
    assert again.calibration() is None


def test_a_negative_block_names_the_field(tmp_path: Path) -> None:
    with pytest.raises(StudyError, match="calibration_block"):
        load_study(study_file(tmp_path, n=-1))


def test_trials_and_steps_read_export_and_fit_together(tmp_path: Path) -> None:
    """A file with trials then play: the reader keeps both, the CSV export has only the steps."""
    clock = FakeClock()
    flow = StudyFlow(load_study(study_file(tmp_path, n=2)), "p03", clock=clock, seed=2, app_version="test")
    block = flow.calibration()
    assert block is not None
    while not block.view().done:
        hold_to(block, clock, block.view().target or 1)
    flow.calibration_ended()
    session = flow.next_block()
    assert session is not None
    session.start()
    session.press("right", at=clock(), repeat=False)
    clock.advance(0.1)
    session.release("right", at=clock())
    flow.quit()
    files = sorted((tmp_path / "data" / "p03").glob("*.jsonl"))
    assert len(files) == 2
    demos = Demonstrations.read(files)
    assert demos.steps == 1 and demos.calibration.shape == (2, 2)
    out = tmp_path / "steps.csv"
    write_csv(out, [read_recording(f) for f in files])
    rows = out.read_text().splitlines()
    assert len(rows) == 2 and "calibration" not in out.read_text()


def test_a_trial_above_the_worlds_levels_is_one_line_naming_the_field(tmp_path: Path) -> None:
    clock = FakeClock()
    flow = StudyFlow(load_study(study_file(tmp_path, n=1)), "p04", clock=clock, seed=2, app_version="test")
    block = flow.calibration()
    assert block is not None
    hold_to(block, clock, 2)
    flow.quit()
    (file,) = (tmp_path / "data" / "p04").glob("*.jsonl")
    bad = tmp_path / "bad.jsonl"
    header = file.read_text().splitlines()[0]
    bad.write_text(header + "\n" + json.dumps({"kind": "calibration_trial", "target": 99, "produced": 2,
                                               "hold_ms": 10.0, "hold_exact": True}) + "\n")
    with pytest.raises(RecordingError, match=r"bad.jsonl:2: target: 99 is above"):
        read_recording(bad)


def test_the_report_gives_each_participant_their_own_trials_and_the_pool_everyones(tmp_path: Path) -> None:
    """The trials' file is tagged practice, which no fit reads: the report still carries its trials to the
    participant's main cells (their hand), and every participant's to the pool."""
    from study.conftest import write_block

    from irl_core.studies.report_cells import gather

    path = study_file(tmp_path, n=2)
    study = load_study(path)
    for participant, short in (("p05", 1), ("p06", 2)):
        clock = FakeClock()
        flow = StudyFlow(study, participant, clock=clock, seed=4, app_version="test")
        block = flow.calibration()
        assert block is not None
        while not block.view().done:
            hold_to(block, clock, (block.view().target or 3) - short)
        flow.quit()
        write_block(study, participant, 0, "main", name="main.jsonl", finished=2)
    data = gather(study)
    by = {cell.participant: cell for cell in data.cells}
    for participant, short in (("p05", 1), ("p06", 2)):
        calibration = by[participant].demos.calibration
        assert calibration.shape == (2, 2) and (calibration[:, 0] - calibration[:, 1] == short).all()
    assert by["pooled"].demos.calibration.shape == (4, 2)


@pytest.mark.parametrize("practice", [1, 0])
def test_a_simulated_participant_holds_the_studys_block_first(tmp_path: Path, practice: int) -> None:
    """Simulated participants (to try a study's report before running people) make the study's calibration block
    too, in a file of its own tagged as their first block, with their own hand: a hasty one two levels short."""
    from irl_core.studies.report_cells import gather
    from irl_core.studies.simulated import SimulatedParticipant, write_simulated_participant

    path = tmp_path / "motor.toml"
    path.write_text(STUDY.format(n=26).replace("practice_episodes = 1", f"practice_episodes = {practice}"))
    study = load_study(path)
    written = write_simulated_participant(study, SimulatedParticipant("p01", None, 5, "hasty"))
    first = read_recording(written[0])
    assert len(first.calibration_trials) == 26 and not first.steps
    assert first.header.study is not None and first.header.study.phase == ("practice" if practice else "main")
    protocol = read_protocol(study, "p01")
    assert protocol.calibration_left == 0 and protocol.finished
    trials = next(cell for cell in gather(study).cells if cell.participant == "p01").demos.calibration
    assert trials.shape == (26, 2) and -3.0 < (trials[:, 1] - trials[:, 0]).mean() < -1.0
    # A study without a block: no trials file.
    plain = tmp_path / "plain"
    plain.mkdir()
    (plain / "motor.toml").write_text(STUDY.format(n=0))
    files = write_simulated_participant(load_study(plain / "motor.toml"), SimulatedParticipant("p01", None, 5, "hasty"))
    assert all(not read_recording(f).calibration_trials for f in files)
