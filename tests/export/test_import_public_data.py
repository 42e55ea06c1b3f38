"""A public human dataset through `careful import` and a fit: ten participants' trial 5 of the Maze Search Task
(nabilbaugher/mst, MIT licence; tests/corpus/tables/maze-search/README.md says where each file comes from).

The dataset keeps each trial's keys as a JSON list in one cell; `moves.csv` is that cell unrolled into one row
per move (`unrolled`, the derivation docs/import.md shows). Everything else is careful import's work: the map
translates the game's x, y and key names, the world file holds the maze, and the reader's checks hold every move
to it (a move through a wall, or a path that does not join, is refused)."""

import csv
import json
from pathlib import Path

from careful_tui.cli import main
from irl_core.irl import FitOptions, fit
from irl_core.irl.intervals.honest import invariant_violations
from irl_core.recordings.demonstrations import Demonstrations, read_recording

CORPUS = Path(__file__).parents[1] / "corpus" / "tables" / "maze-search"
# The game's start cell (its 5) as x, y, and each key's step: only moves the game made are recorded.
START = (1, 1)
STEP = {"up": (0, -1), "down": (0, 1), "left": (-1, 0), "right": (1, 0)}


def unrolled(slice_csv: Path) -> list[dict[str, str]]:
    """One row per move of each trial's key list: the cell it starts from, as the game's x and y."""
    rows = []
    with open(slice_csv, newline="", encoding="utf-8") as handle:
        for entry in csv.DictReader(handle):
            ((trial, keys),) = json.loads(entry["keystroke_sequence"]).items()
            x, y = START
            for move, key in enumerate((k for k in keys if k != "won"), start=1):
                rows.append({"tester_id": entry["tester_id"], "trial": trial, "move": str(move), "x": str(x),
                             "y": str(y), "key": key})
                x, y = x + STEP[key][0], y + STEP[key][1]
    return rows


def test_moves_csv_is_the_slice_unrolled():
    with open(CORPUS / "moves.csv", newline="", encoding="utf-8") as handle:
        assert list(csv.DictReader(handle)) == unrolled(CORPUS / "prolific_data_slice.csv")


def test_the_slice_imports_as_ten_participants_who_each_reach_the_exit_and_fits(tmp_path, capsys):
    code = main(["import", str(CORPUS / "moves.csv"), "--world", str(CORPUS / "maze-5.toml"),
                 "--map", str(CORPUS / "map.toml"), "--out", str(tmp_path / "in")])
    err = capsys.readouterr().err
    assert code == 0, err
    assert err.startswith("imported 10 participants, 10 episodes, 298 steps")
    files = sorted((tmp_path / "in").glob("*.jsonl"))
    assert len(files) == 10
    for path in files:
        ends = list(read_recording(path).episode_ends)
        assert [(e.outcome, e.terminal_symbol) for e in ends] == [("terminal", "G")]
    demonstrations = Demonstrations.read(files)
    assert demonstrations.steps == 298 and demonstrations.episodes == 10
    result = fit(demonstrations, FitOptions(method="maxent", beta=1.0, intervals=True, resamples=20, seed=0), workers=1)
    assert invariant_violations(result) == []
    (g,) = [value for label, value in zip(result.labels, result.theta) if "G" in label]
    # People walk to the exit at a cost of 1 a step: the exit must be worth more than staying away from it.
    assert g > 0
