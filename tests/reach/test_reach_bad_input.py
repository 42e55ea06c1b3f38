"""Bad input to the reach commands, end to end: a bad reach world file or a bad line of a reach recording stops
`careful simulate`, `careful fit`, `careful export` and `careful worlds --show` with exit 2 and one line naming
the file, the line (in a recording) and the field, and writes nothing."""

import json
import tomllib

import pytest

from careful_tui.cli import main
from irl_core.worlds.reach import REACH_WORLDS

GOOD = REACH_WORLDS["reach"].to_toml()


def toml_of(data: dict) -> str:
    """A world's fields as TOML (the test's own writer: nested tables inline)."""
    def value(v):
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return json.dumps(v)
    return "".join(f"{key} = {value(v)}\n" for key, v in data.items())


BAD_WORLDS = [
    ({"regions": [{"symbol": "G", "centre": [390, 80], "radius": 32, "points": 100}]}, "regions.0",
     "reaches outside the field"),
    ({"regions": [{"symbol": "G", "centre": [200, 80], "radius": -3, "points": 100}]}, "regions.0.radius",
     "greater than 0"),
    ({"spread": {"a": -1.0, "b": 0.05}}, "spread.a", "greater than 0"),
    ({"spread": {"a": 2.0, "b": -0.1}}, "spread.b", "greater than or equal to 0"),
    ({"min_ms": 1500.0}, "min_ms", "is not below max_ms"),
]


def one_error_line(capsys) -> str:
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1, error
    return error


@pytest.mark.parametrize(("change", "field", "words"), BAD_WORLDS)
def test_a_bad_world_file_stops_simulate_and_worlds_show_in_one_line(tmp_path, capsys, change, field, words):
    world = tmp_path / "bad.toml"
    world.write_text(toml_of({**tomllib.loads(GOOD), **change}))
    out = tmp_path / "x.jsonl"
    assert main(["simulate", "--world", str(world), "--policy", "hand", "--episodes", "3", "--seed", "0",
                 "--out", str(out)]) == 2
    error = one_error_line(capsys)
    assert f"{world}: {field}" in error and words in error and not out.exists()
    assert main(["worlds", "--show", str(world)]) == 2
    assert f"{world}: {field}" in one_error_line(capsys)


@pytest.fixture
def recording(tmp_path):
    path = tmp_path / "hand.jsonl"
    assert main(["simulate", "--world", "reach", "--policy", "hand", "--episodes", "6", "--seed", "1",
                 "--out", str(path)]) == 0
    return path


@pytest.mark.parametrize(("change", "field", "words"), BAD_WORLDS)
def test_a_recording_whose_header_holds_a_bad_world_names_line_1(recording, tmp_path, capsys, change, field, words):
    lines = recording.read_text().splitlines()
    header = json.loads(lines[0])
    lines[0] = json.dumps({**header, "world": {**header["world"], **change}})
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    for command in (["fit", str(bad), "--no-view"], ["export", str(bad), "--format", "csv", "--out", str(tmp_path / "x.csv")]):
        assert main(command) == 2
        error = one_error_line(capsys)
        # a field's own check names it in the path (world.regions.0.radius); a check across fields after "world: "
        assert (f"{bad}:1: world.{field}" in error or f"{bad}:1: world: {field}:" in error) and words in error
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize(("change", "field", "words"), [
    ({"endpoint": [1.0]}, "endpoint", "a pair of finite numbers"),
    ({"endpoint": "here"}, "endpoint", "a pair of finite numbers"),
    ({"aim": [1.0, None]}, "aim", "a pair of finite numbers"),
    ({"duration_ms": 1500.5}, "duration_ms", "outside the world's 150 to 1500 ms"),
])
def test_a_bad_trial_stops_fit_and_export_naming_file_line_and_field(recording, tmp_path, capsys, change, field, words):
    lines = recording.read_text().splitlines()
    lines[4] = json.dumps({**json.loads(lines[4]), **change})
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    for command in (["fit", str(bad), "--no-view", "--json", str(tmp_path / "fit.json")],
                    ["export", str(bad), "--format", "psych-ds", "--out", str(tmp_path / "dataset")]):
        assert main(command) == 2
        error = one_error_line(capsys)
        assert f"{bad}:5: {field}" in error and words in error
    assert not (tmp_path / "fit.json").exists() and not (tmp_path / "dataset").exists()
