"""Recordings as a CSV table, a Minari dataset or a Psych-DS dataset (docs/environment.md).

CSV: one row per step line, in file order, with the columns of `csv_columns`.

Psych-DS: a folder with ``dataset_description.json`` (a schema.org ``Dataset`` whose ``variableMeasured``
names every column with its unit, `COLUMN_UNITS`) and ``data/study-<name>_participant-<id>_data.csv``, one
file per study (or world, outside a study) and participant: the CSV's rows of their recordings.

Minari: one Minari episode per recorded episode (an episode without steps is skipped):

================  ============================================================
observations      (T + 1,) cells as row * cols + col: each step's cell, then
                  the last step's next cell
actions           (T,) d * L + (c - 1)
rewards           (T,) the recorded rewards, plus the terminal cell's R_S on
                  the step that enters it (what careful/Careful-v0 gives, so
                  they sum to the recorded return)
terminations      (T,) True on the step that enters a terminal cell
truncations       (T,) True on the last step of any other episode (step limit,
                  quit, or a file that ends mid-episode)
infos             (T + 1,) per key, aligned with the observations as Minari's
                  DataCollector records them (entry 0 is the reset, entry
                  t + 1 is step t): ``cell`` (row, col), ``carefulness`` (0 at
                  the reset), ``slipped``, ``hold_ms`` (NaN when not
                  recorded) and ``hold_exact``
================  ============================================================

The dataset names `careful/Careful-v0` with the recordings' world as a mapping of its fields,
so `recover_environment()` rebuilds the same world without the world file.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from irl_core.errors import RecordingError
from irl_core.recordings.demonstrations import Recording
from irl_core.recordings.lines import Step
from irl_core.support.csv_cells import csv_writer, header, text_cell
from irl_core.support.safe_files import built_beside, rename_no_replace, sync_tree, temporary_name
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.mdp import MDP, action_index, build_mdp
from irl_core.worlds.world import World

CSV_COLUMNS = (
    "file", "player", "episode", "t", "row", "col", "direction", "carefulness", "hold_ms",
    "hold_exact", "next_row", "next_col", "slipped", "reward", "score",
)
# A time world's steps (docs/timing.md) add their duration bin (their carefulness is empty).
TIME_COLUMNS = ("bin",)
# A study session's header (docs/studies.md) adds these, from its `study` field.
STUDY_COLUMNS = ("study", "participant", "phase", "world_index")
STUDY_FIELDS = ("name", "participant", "phase", "world_index")
# Each CSV column's unit and meaning, for a Psych-DS dataset's `variableMeasured`.
COLUMN_UNITS: dict[str, tuple[str, str]] = {
    "file": ("none", "the recording the row comes from (its path)"),
    "player": ("none", "the player's name (a study's participant id)"),
    "episode": ("count", "the episode's number in its recording, from 0"),
    "t": ("count", "the move's number in its episode, from 0"),
    "row": ("cell", "the row of the cell the move starts from, 0 at the top"),
    "col": ("cell", "the column of the cell the move starts from, 0 at the left"),
    "direction": ("none", "the direction chosen: up, right, down or left"),
    "carefulness": ("level", "the carefulness level chosen, 1 to the world's levels (empty on a time world)"),
    "hold_ms": ("ms", "how long the key was held, in milliseconds (empty when not recorded)"),
    "hold_exact": ("boolean", "true when a key release timed the hold"),
    "next_row": ("cell", "the row of the cell the move ended in"),
    "next_col": ("cell", "the column of the cell the move ended in"),
    "slipped": ("boolean", "true when the move went another way than chosen"),
    "reward": ("points", "the reward of the move, R_S(s) + R_A(a)"),
    "score": ("points", "the episode's score after the move (undiscounted, from the world's initial score)"),
    "bin": ("index", "a time world's duration bin of the hold, from 0"),
    "study": ("none", "the study's name"),
    "participant": ("none", "the study's participant id"),
    "phase": ("none", "the study phase: practice or main"),
    "world_index": ("index", "the world's place in the study file's worlds, from 0"),
}
PSYCH_DS_CONTEXT = "https://schema.org/"
# Psych-DS file names are keyword-value pairs whose values hold letters and digits only.
_KEYWORD_VALUE = re.compile(r"[^A-Za-z0-9]+")
# Episodes written to a Minari dataset per storage update (and per progress report).
MINARI_BATCH = 200


# ---------------------------------------------------------------------------- CSV


def _study(recording: Recording) -> dict[str, Any] | None:
    study = getattr(recording.header, "study", None)
    if study is None:
        return None
    return study if isinstance(study, dict) else study.model_dump()


def csv_columns(recordings: list[Recording]) -> tuple[str, ...]:
    """The CSV header: the step columns, the bin when any session is of a time world, and the study columns
    when any session has a study."""
    timed = TIME_COLUMNS if any(r.world.care == "time" for r in recordings) else ()
    return CSV_COLUMNS + timed + (STUDY_COLUMNS if any(_study(r) for r in recordings) else ())


def _text(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def csv_rows(recording: Recording, *, study_columns: bool, time_columns: bool = False) -> Iterator[list[str]]:
    """One row per step of `recording`, in `csv_columns` order."""
    study = _study(recording) or {}
    extra = [text_cell(_text(study.get(name))) for name in STUDY_FIELDS] if study_columns else []
    file, player = text_cell(str(recording.path)), text_cell(recording.header.player)
    for s in recording.steps:
        yield [
            file, player, str(s.episode), str(s.t), str(s.state[0]), str(s.state[1]), s.direction,
            _text(s.carefulness), _text(s.hold_ms), _text(s.hold_exact), str(s.next_state[0]),
            str(s.next_state[1]), _text(s.slipped), repr(s.reward), repr(s.score),
            *([_text(s.bin)] if time_columns else []), *extra,
        ]


def write_csv(path: str | Path, recordings: list[Recording], *, progress: Callable[[int], None] | None = None) -> int:
    """Write every step of `recordings` to a new CSV file; returns the number of rows.

    The file is built beside `path` and renamed into place when whole (`safe_files.built_beside`):
    `FileExistsError` if `path` exists by then, and a failure or a kill leaves no file under its
    name. Text cells that would start a formula are made text (`csv_cells.text_cell`).
    `progress(rows)` is called after each recording.
    """
    path = Path(path)
    columns = csv_columns(recordings)
    with built_beside(path) as temporary, open(temporary, "x", encoding="utf-8", newline="") as handle:
        rows = write_table(handle, columns, recordings, done=0, progress=progress)
    return rows


def write_table(handle: TextIO, columns: Sequence[str], recordings: Sequence[Any], *, done: int,
                 progress: Callable[[int], None] | None,
                 rows: Callable[[Any], Iterable[list[str]]] | None = None) -> int:
    """The CSV table of `recordings` (their steps, `columns`; each recording's rows by `rows`, `csv_rows` by
    default) to `handle`; returns `done` plus the rows written, the count `progress` is called with after each
    recording."""
    writer = csv_writer(handle, lineterminator="\r\n")
    writer.writerow(header(columns))
    for recording in recordings:
        writer.writerows(rows(recording) if rows else csv_rows(recording, study_columns=STUDY_COLUMNS[0] in columns,
                                                                time_columns=TIME_COLUMNS[0] in columns))
        done += len(recording.steps)
        if progress:
            progress(done)
    return done


# ---------------------------------------------------------------------------- Psych-DS


def psych_ds_value(text: str) -> str:
    """`text` as a Psych-DS file name's keyword value: its letters and digits only ("p-07" -> "p07")."""
    return _KEYWORD_VALUE.sub("", text)


def psych_ds_files(recordings: Sequence[Any]) -> dict[str, list[Any]]:
    """The Psych-DS data files' names (``study-<name>_participant-<id>_data.csv``), each with its recordings.

    The study is the header's study name (outside a study, the world's name) and the participant the study's
    participant id (outside a study, the player).

    Raises:
        RecordingError: a name without a letter or digit, or two names that become one value (``p-1``, ``p1``).
    """
    files: dict[str, list[Any]] = {}
    named: dict[tuple[str, str], tuple[str, str]] = {}
    for recording in recordings:
        study = _study(recording)
        names = (study["name"], study["participant"]) if study else (recording.world.name, recording.header.player)
        values = (psych_ds_value(names[0]), psych_ds_value(names[1]))
        for what, name, value in zip(("study", "player"), names, values):
            if not value:
                raise RecordingError(recording.path, None, what, f"{printable(name, limit=VALUE_LIMIT)!r} has no letter "
                                     "or digit to name a Psych-DS file with")
        earlier = named.setdefault(values, names)
        if earlier != names:
            raise RecordingError(recording.path, None, "player", f"{printable(names[1], limit=VALUE_LIMIT)!r} of "
                                 f"{printable(names[0], limit=VALUE_LIMIT)!r} and {printable(earlier[1], limit=VALUE_LIMIT)!r} "
                                 f"of {printable(earlier[0], limit=VALUE_LIMIT)!r} both name the Psych-DS file of "
                                 f"study-{values[0]}_participant-{values[1]}: export them separately")
        files.setdefault(f"study-{values[0]}_participant-{values[1]}_data.csv", []).append(recording)
    return files


def psych_ds_description(columns: Sequence[str], *, name: str, description: str,
                         units: Mapping[str, tuple[str, str]] = COLUMN_UNITS) -> dict[str, Any]:
    """``dataset_description.json``: a schema.org Dataset whose `variableMeasured` names every column with its unit
    (from `units`: the grid's columns by default)."""
    return {
        "@context": PSYCH_DS_CONTEXT,
        "@type": "Dataset",
        "name": name,
        "description": description,
        "variableMeasured": [
            {"@type": "PropertyValue", "name": column, "unitText": units[column][0],
             "description": units[column][1]}
            for column in columns
        ],
    }


def write_psych_ds(out: str | Path, recordings: Sequence[Any], *, name: str, description: str,
                   progress: Callable[[int], None] | None = None, columns: Sequence[str] | None = None,
                   units: Mapping[str, tuple[str, str]] = COLUMN_UNITS,
                   rows: Callable[[Any], Iterable[list[str]]] | None = None) -> dict[str, int]:
    """Write `recordings` as a new Psych-DS dataset in the folder `out`; returns each data file's rows by name.

    The folder is built beside `out` and renamed into place whole (`safe_files.built_beside`):
    `FileExistsError` if `out` exists by then, and a failure or a kill leaves nothing under its name.
    Every data file has the same columns (`csv_columns` of all the recordings), its text cells made text
    (`csv_cells.text_cell`). `progress(rows)` is called after each recording. Another kind of recording (a
    reach's) gives its `columns`, their `units` and its `rows` (a recording's rows).
    """
    out = Path(out)
    files = psych_ds_files(recordings)
    columns = csv_columns(list(recordings)) if columns is None else columns
    counts: dict[str, int] = {}
    written = 0
    with built_beside(out) as temporary:
        (temporary / "data").mkdir(parents=True)
        document = psych_ds_description(columns, name=name, description=description, units=units)
        (temporary / "dataset_description.json").write_text(
            json.dumps(document, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
        for file_name, group in files.items():
            with open(temporary / "data" / file_name, "x", encoding="utf-8", newline="") as handle:
                written = write_table(handle, columns, group, done=written, progress=progress, rows=rows)
            counts[file_name] = sum(len(recording.steps) for recording in group)
    return counts


# ---------------------------------------------------------------------------- episodes


@dataclass(frozen=True)
class RecordedEpisode:
    """The steps of one recorded episode (the reader has checked that they form one unbroken path)."""

    path: Path
    number: int
    steps: list[Step]


def recorded_episodes(recording: Recording) -> list[RecordedEpisode]:
    """The episodes of `recording` that have steps, in file order.

    The reader refuses a recording whose steps skip or repeat a `t`, or jump between cells,
    so each episode's steps here are one unbroken path from t = 0.
    """
    grouped: dict[int, list[Step]] = {}
    for step in recording.steps:
        grouped.setdefault(step.episode, []).append(step)
    return [RecordedEpisode(recording.path, number, steps) for number, steps in grouped.items()]


def one_world(recordings: list[Recording]) -> World:
    """The world all `recordings` share; `RecordingError` naming the first that differs."""
    if not recordings:
        raise RecordingError("(no files)", None, None, "no recordings were given")
    world = recordings[0].world
    for other in recordings[1:]:
        if other.world != world:
            raise RecordingError(
                other.path, None, "world",
                f"recorded in world {other.world.name!r}, but {recordings[0].path} is from {world.name!r}: "
                "a Minari dataset holds one world, so export each world's recordings separately",
            )
    return world


def episode_arrays(episode: RecordedEpisode, mdp: MDP) -> dict[str, Any]:
    """One recorded episode as Minari's buffer fields (see the module docstring)."""
    steps, world = episode.steps, mdp.world
    cells = np.array([s.state for s in steps] + [steps[-1].next_state], dtype=np.int64)  # (T + 1, 2)
    last = mdp.state_of[steps[-1].next_state]
    terminated = bool(mdp.terminal[last])
    rewards = np.array([s.reward for s in steps], dtype=np.float64)
    if terminated:
        rewards[-1] += mdp.R_S[last]
    terminations = np.zeros(len(steps), dtype=bool)
    truncations = np.zeros(len(steps), dtype=bool)
    (terminations if terminated else truncations)[-1] = True
    return {
        "observations": cells[:, 0] * world.cols + cells[:, 1],
        "actions": np.array([action_index(s.direction, s.level, world.levels) for s in steps], dtype=np.int64),
        "rewards": rewards,
        "terminations": terminations,
        "truncations": truncations,
        "infos": {
            "cell": cells,
            "carefulness": np.array([0] + [s.level for s in steps], dtype=np.int64),  # the env's c: a bin + 1 on a time world
            "slipped": np.array([False] + [s.slipped for s in steps], dtype=bool),
            "hold_ms": np.array([np.nan] + [np.nan if s.hold_ms is None else s.hold_ms for s in steps]),
            "hold_exact": np.array([False] + [s.hold_exact for s in steps], dtype=bool),
        },
    }


# ---------------------------------------------------------------------------- Minari


def minari_dataset_path(dataset_id: str) -> Path:
    """Where Minari keeps `dataset_id`: under MINARI_DATASETS_PATH when set, ~/.minari/datasets otherwise."""
    from minari.storage.datasets_root_dir import get_dataset_path

    return Path(get_dataset_path(dataset_id))


def check_dataset_id(dataset_id: str) -> str | None:
    """None when `dataset_id` is a Minari id with a version, else why it is not."""
    from minari.dataset.minari_dataset import DATASET_ID_RE

    match = DATASET_ID_RE.fullmatch(dataset_id)
    if match is None or match.group("version") is None:
        return (f"{dataset_id!r} is not a Minari dataset id: use NAME-vN or NAMESPACE/NAME-vN "
                "(letters, digits, '-' and '_'), e.g. careful/paper-human-v0")
    return None


def dataset_place_problem(dataset_id: str) -> str | None:
    """Why `dataset_id` cannot be written (it exists, or lies inside another dataset's folder), or None."""
    root, target = minari_dataset_path(""), minari_dataset_path(dataset_id)
    if target.exists():
        return f"a Minari dataset {dataset_id!r} already exists at {target}"
    for folder in target.parents:
        if folder == root or root not in folder.parents:
            break
        if (folder / "data" / "metadata.json").exists():
            inside = folder.relative_to(root).as_posix()
            return (f"{dataset_id!r} would be written inside the Minari dataset {inside!r} at {folder}; "
                    "choose an id outside it")
    return None


def _ensure_namespace(dataset_id: str) -> None:
    """The dataset's namespace in the real root (Minari makes it on the way, but there it would be built aside)."""
    from minari.dataset.minari_dataset import parse_dataset_id
    from minari.namespace import create_namespace, list_local_namespaces

    namespace = parse_dataset_id(dataset_id)[0]
    if namespace is not None and namespace not in list_local_namespaces():
        try:
            create_namespace(namespace)
        except ValueError:  # another export made it meanwhile
            pass


@contextlib.contextmanager
def _datasets_root(folder: Path) -> Iterator[None]:
    """Minari's datasets root is `folder` inside the block (it reads MINARI_DATASETS_PATH at each call)."""
    saved = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(folder)
    try:
        yield
    finally:
        if saved is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = saved


def write_minari(
    dataset_id: str,
    recordings: list[Recording],
    *,
    description: str,
    progress: Callable[[int], None] | None = None,
) -> Any:
    """Create the local Minari dataset `dataset_id` from `recordings` of one world.

    Returns the `minari.MinariDataset`. Raises `FileExistsError` if the dataset exists (also
    when another export wrote it while this one was built) or the id lies inside another
    dataset, `RecordingError` for recordings of different worlds or with a broken episode, and
    `ValueError` when there is no step to export. The dataset is built in a hidden folder and
    renamed into place whole; a failure removes it. `progress(episodes)` is called after each
    batch of episodes.
    """
    from minari.data_collector import EpisodeBuffer

    from irl_core.worlds.env import ENV_ID

    world = one_world(recordings)
    mdp = build_mdp(world)
    episodes = [e for r in recordings for e in recorded_episodes(r)]
    if not episodes:
        raise ValueError("the recordings hold no steps: there is nothing to export")

    def buffers(start: int) -> list:
        return [
            EpisodeBuffer(id=start + i, **episode_arrays(e, mdp))
            for i, e in enumerate(episodes[start : start + MINARI_BATCH])
        ]

    return create_minari(dataset_id, buffers, len(episodes), env_id=ENV_ID, world=world.model_dump(mode="json"),
                         author={r.header.player for r in recordings}, description=description, progress=progress)


def create_minari(dataset_id: str, buffers: Callable[[int], list], count: int, *, env_id: str,
                  world: dict[str, Any], author: set[str], description: str,
                  progress: Callable[[int], None] | None = None) -> Any:
    """Create the local Minari dataset `dataset_id` of `count` episodes, `buffers(start)` giving the
    `EpisodeBuffer`s from episode `start` on (MINARI_BATCH at a time), naming the environment `env_id` with
    `world`. Returns the `minari.MinariDataset`.

    Built in a hidden root beside the real one (Minari lists no hidden folder), then renamed into place only
    if no dataset took the id meanwhile: a kill leaves no dataset that loads part of the episodes, and two
    exports to one id never delete each other's. Raises `FileExistsError` when the id is taken."""
    import gymnasium as gym
    import minari

    import irl_core.worlds.env  # noqa: F401  (registers the environments)

    target = minari_dataset_path(dataset_id)
    if problem := dataset_place_problem(dataset_id):
        raise FileExistsError(problem)
    _ensure_namespace(dataset_id)
    env = gym.make(env_id, world=world)
    root = minari_dataset_path("")
    building = temporary_name(root / "careful-export")
    try:
        with _datasets_root(building), warnings.catch_warnings():
            # Minari asks for a code link, an e-mail and an evaluation env; recordings have none.
            warnings.filterwarnings("ignore", category=UserWarning, module=r"minari\.")
            dataset = minari.create_dataset_from_buffers(
                dataset_id, buffers(0), env=env, algorithm_name="careful recordings",
                author=author, description=description, data_format="hdf5", requirements=["careful"],
            )
            for start in range(MINARI_BATCH, count, MINARI_BATCH):
                if progress:
                    progress(start)
                dataset.update_dataset_from_buffer(buffers(start))
            del dataset  # its files are closed before they move
        built = building / dataset_id
        sync_tree(built)
        try:
            rename_no_replace(built, target)
        except FileExistsError:
            raise FileExistsError(f"a Minari dataset {dataset_id!r} was written at {target} while this one "
                                  "was built; choose another id") from None
    finally:
        env.close()
        shutil.rmtree(building, ignore_errors=True)
    dataset = minari.load_dataset(dataset_id)
    if progress:
        progress(count)
    return dataset
