"""The ``study`` header field: optional, written when given, and checked like every other field."""

import json
from datetime import UTC, datetime

import pytest

from irl_core.errors import RecordingError
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import SessionHeader, StudyTag
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.world import BUILTIN_WORLDS

TAG = {"name": "pilot", "participant": "p7", "phase": "main", "world_index": 1}


def header(**fields):
    return SessionHeader(world=BUILTIN_WORLDS["paper"], player="p7",
                         created=datetime(2026, 1, 1, tzinfo=UTC), **fields)


def test_a_study_header_is_written_and_read_back(tmp_path):
    path = tmp_path / "s.jsonl"
    RecordingWriter(path, header(study=StudyTag(**TAG))).close()
    assert json.loads(path.read_text())["study"] == TAG
    assert read_recording(path).header.study == StudyTag(**TAG)


def test_a_header_without_it_is_written_as_before(tmp_path):
    path = tmp_path / "s.jsonl"
    RecordingWriter(path, header()).close()
    assert "study" not in json.loads(path.read_text())
    assert read_recording(path).header.study is None


@pytest.mark.parametrize(("change", "field", "problem"), [
    ({"phase": "warmup"}, "study.phase", "Input should be 'practice' or 'main'"),
    ({"world_index": -1}, "study.world_index", "greater than or equal to 0"),
    ({"world_index": True}, "study.world_index", "valid integer"),
    ({"participant": None}, "study.participant", "valid string"),
    ({"extra": 1}, "study.extra", "Extra inputs are not permitted"),
])
def test_a_bad_study_field_is_named_with_file_and_line(tmp_path, change, field, problem):
    path = tmp_path / "s.jsonl"
    RecordingWriter(path, header(study=StudyTag(**TAG))).close()
    line = json.loads(path.read_text())
    line["study"] = {**TAG, **change}
    path.write_text(json.dumps(line) + "\n")
    with pytest.raises(RecordingError) as caught:
        read_recording(path)
    assert str(caught.value).startswith(f"{path}:1: {field}: ")
    assert problem in str(caught.value)


def test_export_adds_the_study_columns_from_a_real_study_header(tmp_path):
    from study.conftest import write_block, write_study

    from irl_core.recordings.export import CSV_COLUMNS, STUDY_COLUMNS, csv_columns, csv_rows
    from irl_core.studies.study import load_study

    study = load_study(write_study(tmp_path))
    path = write_block(study, "p7", 1, "main", name="a.jsonl", finished=2)
    recording = read_recording(path)
    assert csv_columns([recording]) == CSV_COLUMNS + STUDY_COLUMNS
    assert [row[-4:] for row in csv_rows(recording, study_columns=True)] == [["pilot", "p7", "main", "1"]] * 2
