"""Reach recordings as a CSV table, a Psych-DS dataset or a Minari dataset (docs/reach.md, "Exporting").

A trial is one row (CSV, Psych-DS) or one Minari episode of one step, as careful/Reach-v0 plays it:

================  ============================================================
observations      (2, 2): the start, then the endpoint
actions           (1, 3): aim x, aim y, duration in ms
rewards           (1,) the recorded reward
terminations      (1,) True (a trial is one reach)
truncations       (1,) False
infos             (2,) per key, as the env's reset then step: ``aim`` (the
                  start at the reset), ``duration_ms`` (0 at the reset),
                  ``hit`` (0 or 1 per symbol, the world's order)
================  ============================================================

The dataset names careful/Reach-v0 with the recordings' world as a mapping of its fields, so
`recover_environment()` rebuilds it without the world file. The CSV and Psych-DS tables share the grid
exports' safe writing and file naming (`irl_core.recordings.export`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from irl_core.errors import RecordingError
from irl_core.recordings.export import MINARI_BATCH, create_minari, write_psych_ds, write_table
from irl_core.recordings.reach_reader import ReachRecording
from irl_core.support.csv_cells import text_cell
from irl_core.support.safe_files import built_beside
from irl_core.worlds.reach import ReachWorld

REACH_COLUMNS = ("file", "player", "episode", "aim_x", "aim_y", "duration_ms", "endpoint_x", "endpoint_y",
                 "regions", "reward", "score", "hold_exact")
# Each column's unit and meaning, for a Psych-DS dataset's `variableMeasured`.
REACH_COLUMN_UNITS: dict[str, tuple[str, str]] = {
    "file": ("none", "the recording the row comes from (its path)"),
    "player": ("none", "the player's name"),
    "episode": ("count", "the trial's number in its recording, from 0 (a trial is one reach)"),
    "aim_x": ("field unit", "where the reach was aimed, x (right)"),
    "aim_y": ("field unit", "where the reach was aimed, y (down)"),
    "duration_ms": ("ms", "how long the reach took"),
    "endpoint_x": ("field unit", "where the reach ended, x (right)"),
    "endpoint_y": ("field unit", "where the reach ended, y (down)"),
    "regions": ("none", "the symbols of the circles holding the endpoint, separated by spaces (empty: none)"),
    "reward": ("points", "the points of the circles holding the endpoint, less the time cost"),
    "score": ("points", "the session's rewards so far, added up from 0"),
    "hold_exact": ("boolean", "true when the duration was timed exactly"),
}


def reach_rows(recording: ReachRecording) -> Iterator[list[str]]:
    """One row per trial of `recording`, in `REACH_COLUMNS` order (numbers as Python writes them: exact)."""
    file, player = text_cell(str(recording.path)), text_cell(recording.header.player)
    for step in recording.steps:
        yield [file, player, str(step.episode), repr(step.aim[0]), repr(step.aim[1]), repr(step.duration_ms),
               repr(step.endpoint[0]), repr(step.endpoint[1]), text_cell(" ".join(step.regions)), repr(step.reward),
               repr(step.score), "true" if step.hold_exact else "false"]


def write_reach_csv(path: str | Path, recordings: list[ReachRecording], *,
                    progress: Callable[[int], None] | None = None) -> int:
    """Every trial of `recordings` as a new CSV file (built beside `path`, renamed into place whole:
    `FileExistsError` if `path` exists by then); returns the number of rows."""
    with built_beside(Path(path)) as temporary, open(temporary, "x", encoding="utf-8", newline="") as handle:
        return write_table(handle, REACH_COLUMNS, recordings, done=0, progress=progress, rows=reach_rows)


def write_reach_psych_ds(out: str | Path, recordings: list[ReachRecording], *, name: str, description: str,
                         progress: Callable[[int], None] | None = None) -> dict[str, int]:
    """`recordings` as a new Psych-DS dataset in the folder `out` (built beside it, renamed into place whole):
    ``data/study-<world>_participant-<player>_data.csv``, a row per trial; returns each data file's rows."""
    return write_psych_ds(out, recordings, name=name, description=description, progress=progress,
                          columns=REACH_COLUMNS, units=REACH_COLUMN_UNITS, rows=reach_rows)


def one_reach_world(recordings: list[ReachRecording]) -> ReachWorld:
    """The reach world all `recordings` share; `RecordingError` naming the first that differs."""
    world = recordings[0].world
    for other in recordings[1:]:
        if other.world != world:
            raise RecordingError(other.path, None, "world", f"not the world of {recordings[0].path}: a Minari "
                                 "dataset holds one world, so export each world's recordings separately")
    return world


def trial_arrays(world: ReachWorld, recording: ReachRecording, index: int) -> dict[str, Any]:
    """One trial as a Minari episode's buffer fields (the module docstring)."""
    from irl_core.worlds.env import symbol_hits

    step = recording.steps[index]
    return {
        "observations": np.array([world.start, step.endpoint], dtype=np.float64),
        "actions": np.array([[step.aim[0], step.aim[1], step.duration_ms]], dtype=np.float64),
        "rewards": np.array([step.reward], dtype=np.float64),
        "terminations": np.array([True]),
        "truncations": np.array([False]),
        "infos": {"aim": np.array([world.start, step.aim], dtype=np.float64),
                  "duration_ms": np.array([0.0, step.duration_ms]),
                  "hit": np.stack([symbol_hits(world, ()), symbol_hits(world, step.regions)])},
    }


def write_reach_minari(dataset_id: str, recordings: list[ReachRecording], *, description: str,
                       progress: Callable[[int], None] | None = None) -> Any:
    """Create the local Minari dataset `dataset_id`, one episode per trial, naming careful/Reach-v0 with the
    world (`irl_core.recordings.export.create_minari` builds it aside and renames it into place whole).
    Returns the `minari.MinariDataset`.

    Raises `FileExistsError` if the dataset exists (or lies inside another), `RecordingError` for recordings of
    different worlds, `ValueError` when there is no trial."""
    from minari.data_collector import EpisodeBuffer

    from irl_core.worlds.env import REACH_ENV_ID

    world = one_reach_world(recordings)
    trials = [(recording, index) for recording in recordings for index in range(len(recording.steps))]
    if not trials:
        raise ValueError("the recordings hold no trials: there is nothing to export")

    def buffers(start: int) -> list:
        return [EpisodeBuffer(id=start + i, **trial_arrays(world, recording, index))
                for i, (recording, index) in enumerate(trials[start:start + MINARI_BATCH])]

    return create_minari(dataset_id, buffers, len(trials), env_id=REACH_ENV_ID, world=world.model_dump(mode="json"),
                         author={r.header.player for r in recordings}, description=description, progress=progress)
