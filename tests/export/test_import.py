"""`careful import`: a trial table through a column map becomes recordings the reader reads, and every bad row
is named (file, line, column, why) with nothing written; export CSV -> import gives the same recordings back."""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from import_tables import (
    EXPORT_MAP,
    LAB_COLUMNS,
    LAB_MAP,
    SHORT,
    SHORT_STEADY,
    SHORT_TIME,
    play,
    write_lab_table,
    write_map,
)

from careful_tui.cli import main
from irl_core.errors import OutputError, TableError
from irl_core.recordings.demonstrations import Demonstrations, read_recording
from irl_core.recordings.importing import import_table, write_imported
from irl_core.recordings.table_map import load_map
from irl_core.recordings.trial_table import MAX_TABLE_BYTES
from irl_core.worlds.mdp import DIRECTIONS, build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS


def run(capsys, *args) -> tuple[int, list[str]]:
    code = main([str(arg) for arg in args])
    return code, capsys.readouterr().err.splitlines()


# ---------------------------------------------------------------------------- export CSV -> import


def same_recordings(original, imported) -> None:
    """What a table carries comes back: every step's cells, direction, level, hold, reward and score; every end."""
    assert imported.header.player == original.header.player and imported.world == original.world
    assert len(imported.steps) == len(original.steps)
    mdp = build_mdp(original.world)
    for a, b in zip(original.steps, imported.steps):
        assert (a.episode, a.t, a.state, a.direction, a.carefulness, a.bin, a.hold_ms, a.next_state, a.reward, a.score) \
            == (b.episode, b.t, b.state, b.direction, b.carefulness, b.bin, b.hold_ms, b.next_state, b.reward, b.score)
        assert b.hold_exact is False  # a response time is not a timed key release
        intended = mdp.cells[mdp.neighbour[mdp.state_of[a.state], DIRECTIONS.index(a.direction)]]
        # A slip that lands where the chosen move would have (both into walls) cannot be seen in a table.
        assert b.slipped == a.slipped or (intended == a.next_state and not b.slipped)
    assert list(imported.episode_ends) == list(original.episode_ends)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), world=st.sampled_from([SHORT, SHORT_TIME, SHORT_STEADY, BUILTIN_WORLDS["walls"]]))
def test_export_csv_then_import_gives_the_same_recordings(tmp_path_factory, capsys, seed, world):
    folder = tmp_path_factory.mktemp("round")
    session = play(folder / "ada.jsonl", world, seed=seed, episodes=12)
    world_file = folder / "world.toml"
    world_file.write_text(world.to_toml(), encoding="utf-8")
    code, _ = run(capsys, "export", session, "--format", "csv", "--out", folder / "steps.csv")
    assert code == 0
    level = "" if world.care == "time" else 'level = "carefulness"'
    the_map = write_map(folder, EXPORT_MAP.format(level=level))
    code, err = run(capsys, "import", folder / "steps.csv", "--world", world_file, "--map", the_map, "--out", folder / "in")
    assert code == 0, err
    original, imported = read_recording(session), read_recording(folder / "in" / "ada.jsonl")
    same_recordings(original, imported)
    assert err[-1].startswith(f"imported 1 participant, {len(original.episodes)} episode")


def test_the_table_s_coordinates_and_codes_are_translated_by_the_map(tmp_path, capsys):
    # paper: 4 rows x 6 columns. x 0, y 1 from the bottom-left is row 2, column 0.
    table = write_lab_table(tmp_path / "trials.csv", [
        ("s1", 1, 1, 0, 1, "v", 0.5), ("s1", 1, 2, 0, 0, ">", 0.25),   # down to the corner, then into the cliff
        ("s2", "b", 1, 5, 3, "<", 1.0), ("s2", "b", 2, 4, 3, "<", ""),  # along the top row, the last without a time
        ("s2", "a", 7, 0, 3, ">", 0.1),                                 # an episode named, not numbered
    ])
    code, err = run(capsys, "import", table, "--world", "paper", "--map", write_map(tmp_path, LAB_MAP),
                    "--out", tmp_path / "out")
    assert code == 0, err
    assert err == [f"imported 2 participants, 3 episodes, 5 steps from {table} into {tmp_path / 'out'}: s1.jsonl, s2.jsonl"]
    s1 = read_recording(tmp_path / "out" / "s1.jsonl")
    assert [(s.state, s.direction, s.hold_ms, s.next_state) for s in s1.steps] == [
        ((2, 0), "down", 500.0, (3, 0)), ((3, 0), "right", 250.0, (3, 1))]
    assert [(e.outcome, e.terminal_symbol, e.steps, e.score) for e in s1.episode_ends] == [("terminal", "C", 2, -802.0)]
    s2 = read_recording(tmp_path / "out" / "s2.jsonl")
    # "b" and "a" are no numbers: numbered in the order of their first rows.
    assert [(s.episode, s.state, s.next_state, s.hold_ms) for s in s2.steps] == [
        (0, (0, 5), (0, 4), 1000.0), (0, (0, 4), (0, 3), None), (1, (0, 0), (0, 1), 100.0)]
    assert [e.outcome for e in s2.episode_ends] == ["quit", "quit"]
    demonstrations = Demonstrations.read([tmp_path / "out" / "s1.jsonl", tmp_path / "out" / "s2.jsonl"])
    assert demonstrations.steps == 5 and demonstrations.files == 2


def test_json_lines_and_a_json_array_read_as_the_csv_does(tmp_path, capsys):
    rows = [dict(zip(LAB_COLUMNS, row)) for row in [("s1", 1, 1, 0, 1, "v", 0.5), ("s1", 1, 2, 0, 0, ">", 0.25)]]
    (tmp_path / "t.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows), encoding="utf-8")
    (tmp_path / "t.json").write_text(json.dumps(rows, indent=1), encoding="utf-8")
    the_map = write_map(tmp_path, LAB_MAP)
    steps = []
    for name in ("t.jsonl", "t.json"):
        code, err = run(capsys, "import", tmp_path / name, "--world", "paper", "--map", the_map, "--out", tmp_path / name[2:])
        assert code == 0, err
        steps.append([(s.state, s.next_state, s.hold_ms) for s in read_recording(tmp_path / name[2:] / "s1.jsonl").steps])
    assert steps[0] == steps[1] == [((2, 0), (3, 0), 500.0), ((3, 0), (3, 1), 250.0)]


def test_a_cell_index_and_a_row_col_column_name_the_same_cells(tmp_path):
    the_map = 'participant = "p"\nepisode = "e"\nstate = "cell"\naction = "a"\n[actions]\nright = "R"\n'
    write_map(tmp_path, the_map)
    cells = {}
    for name, values in (("index", ["6", "7"]), ("pair", ["1,0", "[1, 1]"])):
        table = tmp_path / f"{name}.tsv"
        table.write_text("p\te\tcell\ta\n" + "".join(f"p1\t0\t{v}\tR\n" for v in values), encoding="utf-8")
        imported = import_table(table, BUILTIN_WORLDS["paper"], load_map(tmp_path / "map.toml"))
        cells[name] = [(s.state, s.next_state) for s in imported.participants["p1"] if hasattr(s, "state")]
    assert cells["index"] == cells["pair"] == [((1, 0), (1, 1)), ((1, 1), (1, 2))]


def test_numeric_codes_and_json_cells_read_as_their_text(tmp_path):
    # A JSON lines table of numbers: participants and directions coded as numbers, cells as [row, col] lists.
    rows = [{"p": 7, "e": 0, "s": [1, 0], "n": [1, 1], "a": 1, "rt": 812},
            {"p": 7, "e": 0, "s": [1, 1], "n": [2, 1], "a": 2.0, "rt": None}]
    (tmp_path / "t.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows), encoding="utf-8")
    the_map = ('participant = "p"\nepisode = "e"\nstate = "s"\nnext_state = "n"\naction = "a"\nrt_ms = "rt"\n'
               "[actions]\nup = 0\nright = 1\ndown = 2\nleft = 3\n")
    imported = import_table(tmp_path / "t.jsonl", BUILTIN_WORLDS["paper"], load_map(write_map(tmp_path, the_map)))
    steps = [line for line in imported.participants["7"] if getattr(line, "kind", "") == "step"]
    assert [(s.state, s.direction, s.next_state, s.hold_ms) for s in steps] == [
        ((1, 0), "right", (1, 1), 812.0), ((1, 1), "down", (2, 1), None)]


# ---------------------------------------------------------------------------- bad input


def refused(capsys, tmp_path, table: Path, the_map: str, world: str = "paper") -> list[str]:
    """The command's lines for a refused table; the output folder must not even exist."""
    out = tmp_path / "out"
    code, err = run(capsys, "import", table, "--world", world, "--map", write_map(tmp_path, the_map), "--out", out)
    assert code == 2
    assert not out.exists()
    return err


@pytest.mark.parametrize("rows, line, column, why", [
    ([("s1", 1, 1, 0, 1, "x", 0.5)], 2, "key", "'x' is not an action code of the map's [actions]"),
    ([("s1", 1, 1, 9, 1, "v", 0.5)], 2, "x,y", "x 9, y 1 is outside the 4x6 grid"),
    ([("s1", 1, 1, 0, 1, "v", "fast")], 2, "rt", "'fast' is not a number"),
    ([("s1", 1, 1, 0, 1, "v", -2)], 2, "rt", "is negative"),
    ([("s1", 1, "first", 0, 1, "v", 0.5)], 2, "move", "'first' is not a number"),
    ([("../s1", 1, 1, 0, 1, "v", 0.5)], 2, "subject", "participant id '../s1' cannot name a recording's file"),
    ([("s1", 1, 1, 0, 2, ">", 0.5), ("s1", 1, 2, 3, 2, ">", 0.5)], 3, "x,y",
     "[1, 3] is not one move from line 2's [1, 0] going right"),
    ([("s1", 1, 1, 4, 1, "v", 0.5), ("s1", 1, 2, 4, 0, "<", 0.5)], 3, "x,y", "[3, 4] is a terminal cell"),
    ([("s1", 1, 1, 0, 1, "v", 0.5), ("s1", 1, 1, 0, 0, ">", 0.5)], 3, "move", "1 is line 2's too"),
])
def test_a_bad_row_is_named_by_file_line_and_column_and_nothing_is_written(tmp_path, capsys, rows, line, column, why):
    table = write_lab_table(tmp_path / "trials.csv", rows)
    err = refused(capsys, tmp_path, table, LAB_MAP)
    assert err[0].startswith(f"careful import: {table}:{line}: {column}: ") and why in err[0], err


def test_every_refused_row_is_named_once_in_the_table_s_order(tmp_path, capsys):
    good = [("s1", 1, i + 1, i, 3, ">", 0.5) for i in range(5)]
    rows = [*good[:1], ("s1", 1, 2, 1, 3, "?", 0.5), *good[2:3], ("s2", 1, 1, 0, 7, ">", 0.5), ("s3", 1, 1, 0, 0, "<", "x")]
    table = write_lab_table(tmp_path / "trials.csv", rows)
    err = refused(capsys, tmp_path, table, LAB_MAP)
    assert [line.split(": ")[1] for line in err[:-1]] == [f"{table}:3", f"{table}:5", f"{table}:6"]
    assert err[-1] == "careful import: 3 problems; nothing was written"


def test_a_map_naming_a_column_the_table_lacks_is_refused_at_the_header(tmp_path, capsys):
    table = write_lab_table(tmp_path / "trials.csv", [("s1", 1, 1, 0, 1, "v", 0.5)])
    err = refused(capsys, tmp_path, table, LAB_MAP.replace('rt_s = "rt"', 'rt_s = "response_time"'))
    assert err[0].startswith(f"careful import: {table}:1: response_time: the map's rt_s names this column, which the "
                             "table does not have (its columns: subject, trial, move, x, y, key, rt)")


def test_a_state_in_a_wall_is_refused(tmp_path, capsys):
    walls = BUILTIN_WORLDS["walls"]
    wall = next((r, c) for r, row in enumerate(walls.grid) for c, ch in enumerate(row) if ch == "#")
    table = tmp_path / "trials.csv"
    table.write_text(f"p,e,r,c,a\np1,0,{wall[0]},{wall[1]},U\n", encoding="utf-8")
    the_map = 'participant = "p"\nepisode = "e"\nstate = ["r", "c"]\naction = "a"\n[actions]\nup = "U"\n'
    err = refused(capsys, tmp_path, table, the_map, world="walls")
    r, c = wall
    assert err[0] == f"careful import: {table}:2: r,c: row {r}, col {c} is [{r}, {c}] in careful's rows and columns, a wall"


def test_a_next_state_a_deterministic_world_cannot_reach_is_refused(tmp_path, capsys):
    # paper-maxent never slips: going right from [0, 0] reaches [0, 1] and nothing else.
    table = tmp_path / "trials.csv"
    table.write_text("p,e,s,n,a\np1,0,0,6,R\np1,0,6,7,R\n", encoding="utf-8")
    the_map = 'participant = "p"\nepisode = "e"\nstate = "s"\nnext_state = "n"\naction = "a"\n[actions]\nright = "R"\n'
    err = refused(capsys, tmp_path, table, the_map, world="paper-maxent")
    assert err[0].startswith(f"careful import: {table}:2: n: the world cannot move from [0, 0] to [1, 0] going right")
    # The same move in a world that slips is a slip, and imports.
    code, _ = run(capsys, "import", table, "--world", "paper", "--map", tmp_path / "map.toml", "--out", tmp_path / "ok")
    assert code == 0 and read_recording(tmp_path / "ok" / "p1.jsonl").steps[0].slipped


def test_mixed_coordinate_systems_are_refused(tmp_path, capsys):
    table = tmp_path / "trials.csv"
    table.write_text('p,e,s,a\np1,0,"0,0",R\np1,0,1,R\n', encoding="utf-8")
    the_map = 'participant = "p"\nepisode = "e"\nstate = "s"\naction = "a"\n[actions]\nright = "R"\n'
    err = refused(capsys, tmp_path, table, the_map)
    assert err[0] == (f"careful import: {table}:3: s: a cell index, but line 2 gave two coordinates: one coordinate "
                      "system per table")


def test_a_table_over_the_limit_is_refused_before_it_is_read(tmp_path, capsys):
    table = tmp_path / "huge.csv"
    with open(table, "wb") as handle:  # sparse: 2 GB on paper, nothing on the disk
        handle.truncate(2 << 30)
    assert os.path.getsize(table) > MAX_TABLE_BYTES
    err = refused(capsys, tmp_path, table, LAB_MAP)
    assert err == [f"careful import: {table}: the table is 2,048 MB; careful imports tables of at most 256 MB "
                   "(split it by participant and import each part)"]


@pytest.mark.parametrize("text, where", [
    ("participant = 1\n", "participant"),
    ('colour = "red"\n' + LAB_MAP, "colour: not a key of a column map"),
    (LAB_MAP + 'north = "N"\n', "actions.north"),
    (LAB_MAP.replace('up = "^"', 'up = ">"'), "actions"),
    (LAB_MAP.replace('axes = "xy"', 'axes = "yx"'), "axes"),
    ('rt_ms = "rt"\n' + LAB_MAP, "the response time's column once"),
])
def test_a_bad_map_is_refused_with_its_key_named(tmp_path, capsys, text, where):
    table = write_lab_table(tmp_path / "trials.csv", [("s1", 1, 1, 0, 1, "v", 0.5)])
    err = refused(capsys, tmp_path, table, text)
    assert err[0].startswith(f"careful import: {tmp_path / 'map.toml'}: ") and where in err[0] and len(err) == 1


def test_an_existing_recording_is_never_overwritten(tmp_path, capsys):
    table = write_lab_table(tmp_path / "trials.csv", [("s1", 1, 1, 0, 1, "v", 0.5), ("s2", 1, 1, 0, 1, "v", 0.5)])
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "s2.jsonl").write_text("mine\n", encoding="utf-8")
    code, err = run(capsys, "import", table, "--world", "paper", "--map", write_map(tmp_path, LAB_MAP),
                    "--out", tmp_path / "out")
    assert code == 2 and "exists already" in err[0] and "never overwrites" in err[0]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["s2.jsonl"]
    assert (tmp_path / "out" / "s2.jsonl").read_text(encoding="utf-8") == "mine\n"


def test_a_wrong_row_in_a_json_array_is_named_by_the_line_it_starts_on(tmp_path, capsys):
    rows = [dict(zip(LAB_COLUMNS, ("s1", 1, 1, 0, 1, "v", 0.5))), dict(zip(LAB_COLUMNS, ("s1", 1, 2, 0, 0, 5, 0.5)))]
    table = tmp_path / "t.json"
    table.write_text(json.dumps(rows, indent=2), encoding="utf-8")  # the second object opens on line 11
    err = refused(capsys, tmp_path, table, LAB_MAP)
    assert err[0].startswith(f"careful import: {table}:11: key: '5' is not an action code")


def test_the_importer_raises_one_table_error_with_every_problem(tmp_path):
    table = write_lab_table(tmp_path / "trials.csv", [("s1", 1, 1, 0, 1, "x", 0.5), ("s1", 1, 2, 0, 0, "y", 0.5)])
    with pytest.raises(TableError) as caught:
        import_table(table, BUILTIN_WORLDS["paper"], load_map(write_map(tmp_path, LAB_MAP)))
    assert len(caught.value.problems) == 2 and str(caught.value).endswith("(and 1 more refused)")


HEADER = ",".join(LAB_COLUMNS)
ROW = dict(zip(LAB_COLUMNS, ("s1", 1, 1, 0, 1, "v", 0.5)))


@pytest.mark.parametrize("name, text, expected", [
    ("t.csv", f"{HEADER}\ns1,1,1,0,1,v,0.5,extra\n", "t.csv:2: the row has 8 cells, but the header (line 1) names 7"),
    ("t.csv", f"{HEADER}\ns1,1,1,0,1,v," + "9" * 200_000 + "\n", "t.csv:2: not a CSV row (field larger than field limit"),
    ("t.json", json.dumps(ROW), "t.json:1: a .json table is an array of objects"),
    ("t.jsonl", f"{json.dumps(ROW)}\n[1, 2]\n", "t.jsonl:2: a row is a JSON object of column: value, not list"),
    ("t.jsonl", f'{json.dumps(ROW)}\n{{"subject": \n', "t.jsonl:2: not valid JSON"),
    ("t.xlsx", "whatever", "t.xlsx: a table's name ends in one of .csv, .tsv, .tab, .jsonl, .ndjson, .json"),
    ("t.csv", "", "t.csv: the table is empty: no header line"),
])
def test_a_table_that_is_not_one_is_named_with_its_line(tmp_path, capsys, name, text, expected):
    table = tmp_path / name
    table.write_text(text, encoding="utf-8")
    err = refused(capsys, tmp_path, table, LAB_MAP)
    assert err[0].startswith(f"careful import: {tmp_path}/{expected}") and len(err) == 1, err


def test_a_write_that_fails_leaves_no_recording_and_no_folder(tmp_path, monkeypatch):
    table = write_lab_table(tmp_path / "trials.csv", [("s1", 1, 1, 0, 1, "v", 0.5), ("s2", 1, 1, 0, 1, "v", 0.5)])
    imported = import_table(table, BUILTIN_WORLDS["paper"], load_map(write_map(tmp_path, LAB_MAP)))
    renamed = []

    def rename_then_fail(source, target):
        if renamed:
            raise OSError(28, "No space left on device")
        os.rename(source, target)
        renamed.append(target)

    monkeypatch.setattr("irl_core.recordings.importing.rename_no_replace", rename_then_fail)
    with pytest.raises(OutputError, match="nothing was imported"):
        write_imported(imported, tmp_path / "out")
    assert renamed and not (tmp_path / "out").exists()


ARROWS = {"up": "^", "down": "v", "left": "<", "right": ">"}


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), spoil=st.booleans())
def test_a_random_walk_imports_as_walked_and_one_spoilt_cell_is_the_one_refusal(tmp_path_factory, seed, spoil):
    rng = np.random.default_rng(seed)
    world = BUILTIN_WORLDS["paper-maxent"]  # never slips: every next cell follows from the move
    mdp = build_mdp(world)
    walked, rows = [], []
    for participant in ("a", "b"):
        for episode in range(int(rng.integers(1, 4))):
            s = mdp.state_of[world.start_cells[int(rng.integers(len(world.start_cells)))]]
            for move in range(int(rng.integers(1, 9))):
                d = int(rng.integers(4))
                r, c = mdp.cells[s]
                rows.append((participant, episode, move + 1, c, world.rows - 1 - r, ARROWS[DIRECTIONS[d]], 0.25))
                walked.append((participant, episode, (r, c), DIRECTIONS[d]))
                s = int(mdp.neighbour[s, d])
                if mdp.terminal[s]:
                    break
    folder = tmp_path_factory.mktemp("walk")
    spoilt = int(rng.integers(len(rows))) if spoil else None
    if spoilt is not None:
        rows[spoilt] = (*rows[spoilt][:5], "?", rows[spoilt][6])
    table = write_lab_table(folder / "walk.csv", rows)
    the_map = load_map(write_map(folder, LAB_MAP))
    if spoilt is not None:
        with pytest.raises(TableError) as caught:
            import_table(table, world, the_map)
        assert caught.value.problems == [f"{table}:{spoilt + 2}: key: '?' is not an action code of the map's [actions] "
                                         "('^', 'v', '<', '>')"]
        return
    imported = import_table(table, world, the_map)
    got = [(p, line.episode, line.state, line.direction) for p, lines in imported.participants.items()
           for line in lines if getattr(line, "kind", "") == "step"]
    assert sorted(got) == sorted(walked)
