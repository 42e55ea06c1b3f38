"""`careful export --format psych-ds`: dataset_description.json names every column with its unit, one keyword-named
CSV per study and participant, text cells safe in a spreadsheet; import -> export psych-ds keeps the table's columns."""

import csv
import json
from datetime import UTC, datetime
from pathlib import Path

from import_tables import LAB_MAP, SHORT, play, write_lab_table, write_map

from careful_tui.cli import main
from irl_core.play.game import Game
from irl_core.recordings.export import COLUMN_UNITS, CSV_COLUMNS, STUDY_COLUMNS, TIME_COLUMNS
from irl_core.recordings.lines import SessionHeader, StudyTag
from irl_core.recordings.writer import RecordingWriter
from irl_core.worlds.world import BUILTIN_WORLDS


def run(capsys, *args) -> tuple[int, list[str]]:
    code = main([str(arg) for arg in args])
    return code, capsys.readouterr().err.splitlines()


def data_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def study_session(path: Path, participant: str, *, study: str = "pilot", player: str | None = None) -> Path:
    world = BUILTIN_WORLDS["paper"]
    header = SessionHeader(world=world, player=player or participant, created=datetime(2026, 1, 1, tzinfo=UTC),
                           study=StudyTag(name=study, participant=participant, phase="main", world_index=0))
    with RecordingWriter(path, header) as writer:
        game = Game(world, seed=1, sink=writer)
        game.begin_episode()
        game.move("up", 3, hold_ms=640.0)
        game.quit()
    return path


def test_a_dataset_names_every_column_with_its_unit_and_a_file_per_study_and_participant(tmp_path, capsys):
    files = [study_session(tmp_path / "a1.jsonl", "p-01"), study_session(tmp_path / "a2.jsonl", "p-01"),
             study_session(tmp_path / "b.jsonl", "p02")]
    code, err = run(capsys, "export", *files, "--format", "psych-ds", "--out", tmp_path / "ds")
    assert code == 0, err
    description = json.loads((tmp_path / "ds" / "dataset_description.json").read_text(encoding="utf-8"))
    assert description["@context"] == "https://schema.org/" and description["@type"] == "Dataset"
    assert description["name"] and description["description"]
    data = sorted((tmp_path / "ds" / "data").iterdir())
    assert [p.name for p in data] == ["study-pilot_participant-p01_data.csv", "study-pilot_participant-p02_data.csv"]
    header = next(csv.reader(open(data[0], encoding="utf-8")))
    assert header == [*CSV_COLUMNS, *STUDY_COLUMNS]
    measured = description["variableMeasured"]
    assert [v["name"] for v in measured] == header
    assert all(v["@type"] == "PropertyValue" and v["unitText"] and v["description"] for v in measured)
    assert {v["name"]: v["unitText"] for v in measured}["hold_ms"] == "ms"
    # Both of p-01's recordings are in p-01's file, p02's in its own.
    assert [(r["file"], r["participant"], r["hold_ms"]) for r in data_rows(data[0])] == [
        (str(files[0]), "p-01", "640.0"), (str(files[1]), "p-01", "640.0")]
    assert len(data_rows(data[1])) == 1
    assert err == [f"wrote a Psych-DS dataset of 3 rows (one per step) in 2 data files from 3 files to {tmp_path / 'ds'}"]


def test_every_column_careful_writes_has_a_unit():
    assert set(COLUMN_UNITS) == {*CSV_COLUMNS, *TIME_COLUMNS, *STUDY_COLUMNS}


def test_a_formula_in_a_name_is_text_in_the_data_file(tmp_path, capsys):
    session = study_session(tmp_path / "x.jsonl", "p1", study='=HYPERLINK("http://x")', player="@SUM(A1)")
    code, _ = run(capsys, "export", session, "--format", "psych-ds", "--out", tmp_path / "ds")
    assert code == 0
    (data,) = (tmp_path / "ds" / "data").iterdir()
    assert data.name == "study-HYPERLINKhttpx_participant-p1_data.csv"
    row = data_rows(data)[0]
    assert row["study"] == "'=HYPERLINK(\"http://x\")" and row["player"] == "'@SUM(A1)"


def test_two_names_that_become_one_file_name_are_refused_and_nothing_is_written(tmp_path, capsys):
    files = [study_session(tmp_path / "a.jsonl", "p-1"), study_session(tmp_path / "b.jsonl", "p1")]
    code, err = run(capsys, "export", *files, "--format", "psych-ds", "--out", tmp_path / "ds")
    assert code == 2 and len(err) == 1 and "study-pilot_participant-p1" in err[0] and str(files[1]) in err[0]
    assert not (tmp_path / "ds").exists()


def test_an_existing_folder_is_never_written_into(tmp_path, capsys):
    session = play(tmp_path / "ada.jsonl", SHORT, seed=3, episodes=2)
    (tmp_path / "ds").mkdir()
    code, err = run(capsys, "export", session, "--format", "psych-ds", "--out", tmp_path / "ds")
    assert code == 2 and "already exists" in err[0]
    assert list((tmp_path / "ds").iterdir()) == []


def test_import_then_export_psych_ds_keeps_the_table_s_columns(tmp_path, capsys):
    table_rows = [("s1", 1, 1, 0, 1, "v", 0.5), ("s1", 1, 2, 0, 0, ">", 0.25), ("s1", 2, 1, 2, 2, "^", 1.5),
                  ("s1", 2, 2, 2, 3, "<", 0.75), ("s2", 1, 1, 5, 3, "<", 2.0)]
    table = write_lab_table(tmp_path / "trials.csv", table_rows)
    code, _ = run(capsys, "import", table, "--world", "paper", "--map", write_map(tmp_path, LAB_MAP), "--out", tmp_path / "in")
    assert code == 0
    code, _ = run(capsys, "export", tmp_path / "in" / "s1.jsonl", tmp_path / "in" / "s2.jsonl", "--format", "psych-ds",
                  "--out", tmp_path / "ds")
    assert code == 0
    exported = {p.name: data_rows(p) for p in (tmp_path / "ds" / "data").iterdir()}
    assert sorted(exported) == ["study-paper_participant-s1_data.csv", "study-paper_participant-s2_data.csv"]
    arrows = {"^": "up", "v": "down", "<": "left", ">": "right"}
    back = [row for name in sorted(exported) for row in exported[name]]
    # Each table row, its columns read back from the data file: the cell (x, y from the bottom-left), the
    # action, the response time in ms, the participant and the episode, in the table's order.
    for original, row in zip(table_rows, back, strict=True):
        subject, trial, _, x, y, key, rt = original
        assert (row["player"], int(row["episode"]), int(row["col"]), 3 - int(row["row"]), row["direction"],
                float(row["hold_ms"])) == (subject, trial, x, y, arrows[key], rt * 1000)
