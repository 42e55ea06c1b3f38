"""Reading demonstrations (recordings/README.md): a strict reader and the `Demonstrations` a fit uses.

A file is one play session: a ``session`` header line, then ``step`` lines and
``episode_end`` lines as they happen (`irl_core.recordings.lines` holds their models,
`irl_core.recordings.writer` writes them). The reader streams the file, validates every line
and that the lines agree with each other (episodes in order, ``t`` counting up, each step
starting where the last one ended) and reports ``file:line: field: problem``; a truncated
last line (the crash case) is skipped with a warning. A step may say which way the move
really went (``realised``, optional: older files without it still read).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, BinaryIO

import numpy as np
import scipy.sparse as sp
from pydantic import Field, TypeAdapter, ValidationError

from irl_core.errors import EmptyRecording, Mismatch, RecordingError
from irl_core.recordings.end_table import EndTable
from irl_core.recordings.line_checks import LineChecker
from irl_core.recordings.lines import SCHEMA_VERSION, CalibrationTrial, EpisodeEnd, SessionHeader, Step
from irl_core.recordings.step_table import StepTable
from irl_core.support.safe_files import open_regular, read_problem
from irl_core.support.safe_text import VALUE_LIMIT, printable
from irl_core.worlds.mdp import MDP, build_mdp
from irl_core.worlds.world import World
from irl_core.worlds.world_text import field_path

_BODY = TypeAdapter(Annotated[Step | EpisodeEnd | CalibrationTrial, Field(discriminator="kind")])


# ---------------------------------------------------------------------------- reading

# A longer line is refused before it is parsed (a header with the largest allowed world is far shorter).
MAX_LINE_BYTES = 64 << 20
_BOM = b"\xef\xbb\xbf"


@dataclass
class Recording:
    """One session file as read: its header, steps, episode ends and any warnings.

    `steps` is a `StepTable` and `episode_ends` an `EndTable`: sequences of `Step` and
    `EpisodeEnd` stored as columns.
    """

    path: Path
    header: SessionHeader
    steps: StepTable = field(default_factory=StepTable)
    episode_ends: EndTable = field(default_factory=EndTable)
    warnings: list[str] = field(default_factory=list)
    # A study's motor calibration block (none in most files): they are no steps and no fit counts them.
    calibration_trials: list[CalibrationTrial] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not isinstance(self.episode_ends, EndTable):  # a list of ends, as a test or a caller builds one
            self.episode_ends = EndTable(self.episode_ends)

    @property
    def world(self) -> World:
        return self.header.world

    @property
    def episodes(self) -> list[int]:
        """Episode numbers that have a step or an end, in order (the reader checks that order)."""
        return np.union1d(self.steps.column("episode"), self.episode_ends.column("episode")).tolist()


def read_recording(path: str | Path, *, progress: Callable[[int], None] | None = None) -> Recording:
    """Read and validate one JSONL session file, a line at a time.

    Raises `RecordingError` naming the file, line and field of the first problem (an
    `EmptyRecording` for a file without lines), and for anything that is not a regular file
    (a FIFO is refused, not waited on). A last line cut off without its newline (a crash
    mid-write) is skipped with a warning. `progress` is called with the bytes read since
    its last call, every few thousand lines.
    """
    path = Path(path)
    with open_recording(path) as file:
        try:
            return _read_lines(path, file, progress)
        except OSError as exc:
            raise RecordingError(path, None, None, f"cannot read the file ({read_problem(exc)})") from None
        except RecordingError:
            raise
        except (ValueError, OverflowError, TypeError, IndexError) as exc:  # the last net: no other error escapes
            raise RecordingError(path, None, None, f"cannot be read ({type(exc).__name__}: {exc})") from None


def open_recording(path: Path) -> BinaryIO:
    """`path` opened to be read as a recording (a regular file), or a `RecordingError` saying why it cannot be."""
    try:
        return open_regular(path)
    except OSError as exc:
        raise RecordingError(path, None, None, f"cannot read the file ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise RecordingError(path, None, None, f"is {exc}; a recording is a file") from None


def _read_lines(path: Path, file: Any, progress: Callable[[int], None] | None) -> Recording:
    recording: Recording | None = None
    number = unreported = 0
    while data := file.readline(MAX_LINE_BYTES + 1):
        number += 1
        unreported += len(data)
        if progress is not None and number % 4096 == 0:
            progress(unreported)
            unreported = 0
        ends_cleanly = data.endswith(b"\n")
        if not ends_cleanly and len(data) > MAX_LINE_BYTES:
            raise RecordingError(path, number, None, f"the line is longer than {MAX_LINE_BYTES >> 20} MB")
        if number == 1 and data.startswith(_BOM):
            data = data[len(_BOM):]
        text = data.rstrip(b"\n").rstrip(b"\r")
        if not text.strip():
            continue
        if recording is not None:
            # The common case, parsed and validated in one pass; any problem is re-read below to name it.
            try:
                line = _BODY.validate_json(text)
            except ValidationError:
                line = None
        if recording is None or line is None:
            try:
                obj = json.loads(text.decode("utf-8"))
            except (ValueError, RecursionError) as exc:  # not JSON, not UTF-8, or a number of over 4,300 digits
                if not ends_cleanly and recording is not None:
                    recording.warnings.append(f"{path}:{number}: the last line is truncated and was skipped")
                    break
                raise RecordingError(path, number, None, json_problem(exc)) from None
            obj = line_object(obj, path, number)
            if recording is None:
                recording = Recording(path=path, header=_read_header(obj, path, number))
                checker = LineChecker(build_mdp(recording.world))
                continue
            try:
                line = _BODY.validate_python(obj)
            except ValidationError as exc:
                raise line_error(path, number, exc, obj) from None
        try:
            if isinstance(line, Step):
                checker.step(line, number)
                recording.steps.append(line)
            elif isinstance(line, CalibrationTrial):
                checker.trial(line, number)
                recording.calibration_trials.append(line)
            else:
                checker.end(line, number)
                recording.episode_ends.append(line)
        except Mismatch as exc:
            raise RecordingError(path, exc.line, exc.field, exc.problem) from None
    if progress is not None:
        progress(unreported)
    if recording is None:
        raise EmptyRecording(path, None, None, "the file is empty: no session header")
    return recording


def read_recordings(
    paths: Iterable[str | Path], *, progress: Callable[[int], None] | None = None
) -> tuple[list[Recording], list[str]]:
    """Read several recordings for one use (a fit); returns them and every warning, in order.

    A file given twice (by the same or another path: same device and inode) is read once, and
    an empty file is skipped, each with a warning; if every file is empty, that is an error.

    Raises:
        RecordingError: the first bad file (see `read_recording`).
    """
    recordings: list[Recording] = []
    warnings: list[str] = []
    seen: dict[tuple[int, int], Path] = {}
    empty: list[Path] = []
    for path in map(Path, paths):
        try:
            info = os.stat(path)
            key = (info.st_dev, info.st_ino)
        except OSError:
            key = None
        if key is not None and key in seen:
            same = "given twice" if seen[key] == path else f"the same file as {seen[key]}"
            warnings.append(f"{path}: {same}; read once")
            continue
        if key is not None:
            seen[key] = path
        try:
            recording = read_recording(path, progress=progress)
        except EmptyRecording:
            empty.append(path)
            warnings.append(f"{path}: the file is empty (no session header); skipped")
            continue
        warnings.extend(recording.warnings)
        recordings.append(recording)
    if not recordings and len(empty) == 1:
        raise EmptyRecording(empty[0], None, None, "the file is empty: no session header")
    if not recordings and empty:
        names = ", ".join(str(p) for p in empty)
        raise EmptyRecording(names, None, None, "every file given is empty: no session header")
    return recordings, warnings


def line_object(obj: Any, path: Path, number: int) -> dict:
    """A line's parsed JSON, if it is an object holding only text a file can carry; else a `RecordingError`."""
    if not isinstance(obj, dict):
        raise RecordingError(path, number, None, "a line must be a JSON object")
    if (where := lone_surrogate(obj)) is not None:
        raise RecordingError(path, number, where, "holds a lone surrogate (\\udXXX), which is not text; "
                             "the file was not written by careful")
    return obj


def json_problem(exc: Exception) -> str:
    """What is wrong with a line `json.loads` refused, in a few words."""
    if isinstance(exc, UnicodeDecodeError):
        return "not UTF-8 text"
    if isinstance(exc, RecursionError):
        return "not valid JSON (arrays or objects nested too deeply)"
    if isinstance(exc, json.JSONDecodeError):
        return f"not valid JSON ({exc.msg})"
    return "a number is over 4,300 digits long"


def lone_surrogate(value: Any, where: str = "") -> str | None:
    """The field (`player`, `world.name`, ...) of the first string or key in `value` that holds
    a lone surrogate (JSON's `"\\ud800"`, which no UTF-8 file or terminal can carry), or None."""
    if isinstance(value, str):
        return where or "(value)" if any("\ud800" <= ch <= "\udfff" for ch in value) else None
    if isinstance(value, dict):
        for key, item in value.items():
            if (found := lone_surrogate(key, where) or lone_surrogate(item, f"{where}.{key}".lstrip("."))) is not None:
                return found
    elif isinstance(value, list):
        for i, item in enumerate(value):
            if (found := lone_surrogate(item, f"{where}[{i}]")) is not None:
                return found
    return None


def _brief(value: Any) -> str:
    """A value from the file, as JSON, short enough for a one-line message."""
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def _read_header(obj: dict, path: Path, number: int) -> SessionHeader:
    check_header(obj, path, number)
    if isinstance(obj.get("world"), dict) and obj["world"].get("care") == "reach":
        raise RecordingError(path, number, "world.care", "a reach recording, which careful fit reads; "
                             "this command does not take reach recordings yet")
    try:
        return SessionHeader.model_validate(obj)
    except ValidationError as exc:
        raise line_error(path, number, exc, obj) from None


def check_header(obj: dict, path: Path, number: int) -> None:
    """That `obj` (line `number`) is a session header of the schema this careful reads, or a `RecordingError`."""
    if obj.get("kind") != "session":
        raise RecordingError(
            path, number, "kind", f"the first line must be the session header, not {_brief(obj.get('kind'))}"
        )
    if "schema" not in obj:
        raise RecordingError(path, number, "schema", "missing")
    schema = obj["schema"]
    # `true == 1` in Python: the type is checked too.
    if type(schema) is not int or schema != SCHEMA_VERSION:
        raise RecordingError(
            path, number, "schema",
            f"schema version {_brief(schema)} is not supported (this careful reads version {SCHEMA_VERSION}); "
            "a newer careful may read it",
        )


def line_error(path: Path, number: int, exc: ValidationError, obj: dict) -> RecordingError:
    """A line's first validation problem as `file:line: field: problem`, quoting the value found."""
    first = exc.errors()[0]
    loc = list(first["loc"])
    # The discriminated union puts the kind first in the location: drop it.
    if loc and loc[0] == obj.get("kind"):
        loc = loc[1:]
    name = field_path(loc) or "kind"
    problem = first["msg"].removeprefix("Value error, ")
    if first["type"] == "missing":
        problem = "missing"
    elif "input" in first and first["type"] != "extra_forbidden":
        problem = f"{problem} (got {_brief(first['input'])})"
    return RecordingError(path, number, name, problem)


# ---------------------------------------------------------------------------- using


@dataclass(frozen=True)
class Demonstrations:
    """Every step of one or more recordings of the same world, as counts.

    Attributes:
        mdp: the world's MDP (from the recordings' headers).
        counts: (S, A) N(s, a), how often action a was demonstrated in state s.
        files, episodes, steps: how much was read.
        by_episode: (E, S * A) sparse, row e the counts of the e-th episode with steps (so that
            resampling episodes is a weighted sum of rows); None when only the counts are known.
        episode_groups: (E,) the group (a study's participant) of each row of `by_episode`: a
            bootstrap then resamples groups, then episodes within them; None: episodes are
            independent.
        episode_facts: how each of those episodes began, how long it was and how it ended (the fit
            check compares them with the fitted player's); None when not known.
        calibration: (n, 2) the motor calibration trials' (target, produced) levels, in file order
            (n = 0 without any): the people fit estimates the hand from them.
        hold_steps: (m, 5) on a time world each step with a recorded hold as (state, chosen direction index,
            hold_ms, slipped 0/1, row of `by_episode`), in file order: the slips teach the slip curve
            (`irl_core.irl.timing.slip_curve`), the holds the timing fit (`irl_core.irl.timing.fit`); m = 0 on a
            world with levels.
    """

    mdp: MDP
    counts: np.ndarray
    files: int
    episodes: int
    steps: int
    by_episode: sp.csr_matrix | None = None
    episode_groups: np.ndarray | None = None
    episode_facts: EpisodeFacts | None = None
    calibration: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    hold_steps: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))

    @classmethod
    def from_recordings(cls, recordings: list[Recording]) -> Demonstrations:
        """Pool recordings; raises `RecordingError` if they come from different worlds."""
        if not recordings:
            raise RecordingError("(no files)", None, None, "no recordings were given")
        world = recordings[0].world
        for other in recordings[1:]:
            if other.world != world:
                differ = ", ".join(k for k in World.model_fields if getattr(other.world, k) != getattr(world, k))
                raise RecordingError(
                    other.path, None, "world",
                    f"recorded in world {printable(other.world.name, limit=VALUE_LIMIT)!r}, but {recordings[0].path} is from "
                    f"{printable(world.name, limit=VALUE_LIMIT)!r} (they differ in {differ}): "
                    "fit recordings of one world at a time",
                )
        mdp = build_mdp(world)
        counts = np.zeros((mdp.n_states, mdp.n_actions))
        index = np.full((world.rows, world.cols), -1, dtype=np.int64)
        for cell, s in mdp.state_of.items():
            index[cell] = s

        def column(name: str) -> np.ndarray:
            return np.concatenate([np.empty(0, np.int64)] + [r.steps.column(name) for r in recordings]).astype(np.int64)

        states = index[column("row"), column("col")]
        actions = column("direction") * world.levels + column("level") - 1
        if states.size:
            np.add.at(counts, (states, actions), 1.0)
        files = np.concatenate([np.empty(0, np.int64)] + [np.full(len(r.steps), i) for i, r in enumerate(recordings)])
        episode_keys = list(zip(files.tolist(), column("episode").tolist()))
        row_of_step = episode_rows(episode_keys)
        endings = {(i, end.episode): end for i, r in enumerate(recordings) for end in r.episode_ends}
        return cls(
            mdp=mdp,
            counts=counts,
            files=len(recordings),
            episodes=sum(len(r.episodes) for r in recordings),
            steps=sum(len(r.steps) for r in recordings),
            by_episode=episode_matrix(row_of_step, states * mdp.n_actions + actions, mdp.n_states * mdp.n_actions),
            episode_facts=EpisodeFacts.of_steps(episode_keys, states, endings),
            calibration=np.array([(t.target, t.produced) for r in recordings for t in r.calibration_trials],
                                 dtype=np.int64).reshape(-1, 2),
            hold_steps=(hold_steps(states, column("direction"), np.concatenate(
                [np.empty(0)] + [r.steps.column("hold_ms") for r in recordings]), np.concatenate(
                [np.empty(0, bool)] + [r.steps.column("slipped") for r in recordings]), row_of_step)
                if world.care == "time" else np.zeros((0, 5))),
        )

    @classmethod
    def read(cls, paths: Sequence[str | Path]) -> Demonstrations:
        return cls.from_recordings(read_recordings(paths)[0])

    @property
    def slip_outcomes(self) -> np.ndarray:
        """(m, 2) (hold_ms, slipped 0/1) of every step with a recorded hold (a time world's)."""
        return self.hold_steps[:, 2:4]

    @property
    def demonstrated(self) -> np.ndarray:
        """(S,) True where at least one action was demonstrated."""
        return self.counts.sum(axis=1) > 0

    @property
    def policy(self) -> np.ndarray:
        """(S, A) empirical action frequencies pi(s, a); rows of undemonstrated states are 0."""
        totals = self.counts.sum(axis=1, keepdims=True)
        return np.divide(self.counts, totals, out=np.zeros_like(self.counts), where=totals > 0)

    @property
    def most_frequent(self) -> np.ndarray:
        """(S,) the most frequent demonstrated action (lowest index among ties); -1 if none."""
        return np.where(self.demonstrated, self.counts.argmax(axis=1), -1)


def hold_steps(states: np.ndarray, directions: np.ndarray, hold_ms: np.ndarray, slipped: np.ndarray,
               row_of_step: np.ndarray) -> np.ndarray:
    """(m, 5) `Demonstrations.hold_steps` from per-step (n,) states, chosen direction indices, holds (NaN where
    none was recorded), slips and rows of `by_episode` (`episode_rows`)."""
    hold_ms = np.asarray(hold_ms, dtype=float)
    keep = np.isfinite(hold_ms)
    table = np.column_stack([states, directions, hold_ms, np.asarray(slipped, dtype=float), row_of_step]).reshape(-1, 5)
    return table[keep]


UNFINISHED = "unfinished"


@dataclass(frozen=True)
class EpisodeFacts:
    """Per episode with steps (the rows of `Demonstrations.by_episode`, in order): start (E,) its first
    state, length (E,) its steps, end (E,) how it ended: a terminal symbol, ``step_limit``, ``quit``, or
    ``unfinished`` (no ``episode_end`` line)."""

    start: np.ndarray
    length: np.ndarray
    end: tuple[str, ...]

    @classmethod
    def of_steps(cls, episode_of_step: list, state_of_step: np.ndarray, endings: dict) -> EpisodeFacts:
        """From each step's episode key and state (in order) and the `EpisodeEnd` lines by key."""
        keys = list(dict.fromkeys(episode_of_step))
        first: dict = {}
        length: dict = {}
        for key, state in zip(episode_of_step, np.asarray(state_of_step).tolist()):
            first.setdefault(key, state)
            length[key] = length.get(key, 0) + 1
        ends = []
        for key in keys:
            end = endings.get(key)
            ends.append(UNFINISHED if end is None else
                        (end.terminal_symbol or "terminal") if end.outcome == "terminal" else end.outcome)
        return cls(start=np.array([first[k] for k in keys], dtype=np.int64),
                   length=np.array([length[k] for k in keys], dtype=np.int64), end=tuple(ends))

    def rows(self, keep: np.ndarray) -> EpisodeFacts:
        """The facts of the episodes where `keep` (E,) is True."""
        keep = np.asarray(keep, dtype=bool)
        return EpisodeFacts(start=self.start[keep], length=self.length[keep],
                            end=tuple(end for end, kept in zip(self.end, keep) if kept))

    @property
    def finished(self) -> np.ndarray:
        """(E,) True where the episode ran to a terminal cell or the step limit (not quit, not cut short)."""
        return np.array([end not in ("quit", UNFINISHED) for end in self.end], dtype=bool)


def episode_rows(episode_of_step: list) -> np.ndarray:
    """(steps,) the row of each step's episode: the episodes numbered 0, 1, ... by first appearance of their key."""
    index: dict = {}
    return np.array([index.setdefault(key, len(index)) for key in episode_of_step], dtype=np.int64)


def episode_matrix(row_of_step: np.ndarray, pair_of_step: np.ndarray, n_pairs: int) -> sp.csr_matrix:
    """(E, n_pairs) per-episode counts: row e counts the pairs (s * A + a) of the steps of episode row e.

    Args:
        row_of_step: (steps,) each step's episode row, 0, 1, ... (`episode_rows`).
        pair_of_step: (steps,) the state-action index s * A + a of each step.
    """
    n_rows = int(row_of_step.max()) + 1 if row_of_step.size else 0
    matrix = sp.csr_matrix((np.ones(row_of_step.size), (row_of_step, np.asarray(pair_of_step, dtype=np.int64))),
                           shape=(n_rows, n_pairs))
    matrix.sum_duplicates()
    return matrix
