"""Demonstrations as JSONL files (SPEC section 2): models, a crash-safe writer, a strict reader.

A file is one play session: a ``session`` header line, then ``step`` lines and
``episode_end`` lines as they happen. The writer (`RecordingWriter`, and `SessionRecorder`
for a game) never overwrites, flushes every line and fsyncs at each episode end, so a crash
loses at most the line in flight; it never leaves an empty file, and never writes a number
JSON cannot hold. The reader streams the file, validates every line and that the lines
agree with each other (episodes in order, ``t`` counting up, each step starting where the
last one ended) and reports ``file:line: field: problem``; a truncated last line (the crash
case) is skipped with a warning. A step may say which way the move really went
(``realised``, optional: older files without it still read).
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import scipy.sparse as sp
from pydantic import Field, TypeAdapter, ValidationError

from irl_core.line_checks import LineChecker, Mismatch
from irl_core.mdp import MDP, build_mdp
from irl_core.safe_files import open_regular
from irl_core.recording_lines import SCHEMA_VERSION, EpisodeEnd, SessionHeader, Step, StudyTag, _Line  # noqa: F401 (read from here)
from irl_core.safe_text import VALUE_LIMIT, cut, printable
from irl_core.step_table import StepTable
from irl_core.world import World, field_path

class RecordingError(ValueError):
    """A recording that cannot be used. `str()` is `file:line: field: problem`."""

    def __init__(self, path: str | Path, line: int | None, field: str | None, problem: str):
        self.path, self.line, self.field, self.problem = str(path), line, field, problem
        where = cut(self.path, 200) if line is None else f"{cut(self.path, 200)}:{line}"
        field = None if field is None else cut(field, VALUE_LIMIT)
        super().__init__(f"{where}: {field}: {problem}" if field else f"{where}: {problem}")


_BODY = TypeAdapter(Annotated[Step | EpisodeEnd, Field(discriminator="kind")])


def to_json_line(line: _Line) -> str:
    """One JSONL line (with its newline) in SPEC field names.

    Raises:
        ValueError: a number JSON cannot hold (NaN, Infinity); nothing is written for it.
    """
    data = line.model_dump(mode="json", by_alias=True)
    for optional in ("realised", "study"):
        if data.get(optional, "") is None:
            del data[optional]
    return json.dumps(data, ensure_ascii=False, allow_nan=False) + "\n"


def _encoded(line: _Line) -> bytes:
    """`to_json_line` as UTF-8; a name holding undecodable bytes is a `ValueError`, raised before any write."""
    try:
        return to_json_line(line).encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("a name holds bytes that are not UTF-8 text") from None


# ---------------------------------------------------------------------------- writing


class RecordingLost(OSError):
    """The file being written was deleted (or its folder was): what is written now goes nowhere."""


class RecordingWriter:
    """Appends a session's lines to a new file as they happen.

    The file is created exclusively (an existing file is never overwritten) and only once its
    header is known to be writable: a header that cannot be encoded is refused before the file
    exists, and a header that cannot be written (a full disk) removes the file again, so no
    empty recording is left behind. Each line is written at once (unbuffered), and the file is
    fsynced at every episode end and on close. After each write the writer checks that the file
    is still linked into a folder; if not it raises `RecordingLost`. `sync_episodes=False` skips
    the per-episode fsync, for bulk output that can simply be written again (simulated experts).

    Raises (from the constructor and every write):
        FileExistsError: the path exists.
        OSError: the file cannot be created or written (full disk, read-only folder, long name).
        RecordingLost: the file was deleted while being written.
        ValueError: a line holds a number JSON cannot hold, or a name that is not UTF-8 text.
    """

    def __init__(self, path: str | Path, header: SessionHeader, *, sync_episodes: bool = True):
        self.path = Path(path)
        self._sync_episodes = sync_episodes
        first = _encoded(header)
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND | getattr(os, "O_CLOEXEC", 0)
        self._fd: int | None = os.open(self.path, flags, 0o666)
        try:
            self._write_bytes(first)
            self.sync()
        except BaseException:
            self._discard()
            raise

    @classmethod
    def create_in(cls, folder: str | Path, header: SessionHeader) -> RecordingWriter:
        """A writer for a new file in `folder` (created if missing), named by the time and player.

        Two sessions started in the same second get distinct names (`-2`, `-3`, ...).
        """
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        stem = f"{header.created:%Y%m%d-%H%M%S}-{slug(header.player)}"
        for n in range(1, 1000):
            path = folder / (f"{stem}.jsonl" if n == 1 else f"{stem}-{n}.jsonl")
            try:
                return cls(path, header)
            except FileExistsError:
                continue
        raise FileExistsError(f"{folder}: too many sessions named {stem}")

    def write_step(self, step: Step) -> None:
        self._write_bytes(_encoded(step))

    def end_episode(self, end: EpisodeEnd) -> None:
        self._write_bytes(_encoded(end))
        if self._sync_episodes:
            self.sync()

    def write_many(self, lines: Iterable[Step | EpisodeEnd]) -> None:
        """Several lines in one write (bulk output): encoded first, so a bad one writes nothing."""
        self._write_bytes(b"".join(_encoded(line) for line in lines))

    def close(self) -> None:
        if self._fd is not None:
            try:
                self.sync()
            finally:
                os.close(self._fd)
                self._fd = None

    def abandon(self) -> None:
        """Close without syncing (the file is gone or cannot be written)."""
        if self._fd is not None:
            try:
                os.close(self._fd)
            except OSError:
                pass
            self._fd = None

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _write_bytes(self, data: bytes) -> None:
        if self._fd is None:
            raise ValueError(f"{self.path} is closed")
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view):]
        if os.fstat(self._fd).st_nlink == 0:
            raise RecordingLost(f"{self.path} was deleted while it was being written")

    def sync(self) -> None:
        """Flush the file to disk."""
        os.fsync(self._fd)
        if os.fstat(self._fd).st_nlink == 0:
            raise RecordingLost(f"{self.path} was deleted while it was being written")

    def _discard(self) -> None:
        self.abandon()
        try:
            os.unlink(self.path)
        except OSError:
            pass


class SessionRecorder:
    """A game's session file in `folder`, created (named by time and player) at its first line.

    `header` is the session header without its time; `created` is filled in when the file is
    created. `set_header` before anything was written replaces the header; after, it closes the
    file and the next line starts a new session file with the new header.

    Nothing played is lost to a folder deleted mid-session: the recorder keeps the lines of
    the file it writes (a person's session is small), and when the file turns out to be
    deleted it recreates the folder, writes them all to a new session file and goes on there;
    `notices` tells the player. A file that cannot be written at all raises `OSError`.
    """

    def __init__(self, folder: str | Path, header: SessionHeader) -> None:
        self.folder = Path(folder)
        self.header = header
        self.paths: list[Path] = []
        self.lost: list[Path] = []
        self.notices: list[str] = []
        self._writer: RecordingWriter | None = None
        self._lines: list[Step | EpisodeEnd] = []

    @property
    def path(self) -> Path | None:
        """The file being written, or None before the first line (or after a header change)."""
        return None if self._writer is None else self._writer.path

    def set_header(self, header: SessionHeader) -> None:
        self.close()
        self.header = header

    def write_step(self, step: Step) -> None:
        self._record(step, lambda writer: writer.write_step(step))

    def end_episode(self, end: EpisodeEnd) -> None:
        self._record(end, lambda writer: writer.end_episode(end))

    def close(self) -> None:
        if self._writer is None:
            return
        try:
            self._writer.close()
        except RecordingLost:
            self._recover()
            self._writer.close()
        self._writer = None
        self._lines = []

    def _record(self, line: Step | EpisodeEnd, write: Callable[[RecordingWriter], None]) -> None:
        self._lines.append(line)
        try:
            write(self._open())
        except RecordingLost:
            self._recover()
        except BaseException:
            self._lines.pop()
            raise

    def _recover(self) -> None:
        """The file was deleted: write everything it held to a new file in a recreated folder."""
        if self._writer is not None:
            lost = self._writer.path
            self._writer.abandon()
            self._writer = None
            self.lost.append(lost)
            self.paths.remove(lost)
        writer = self._open()
        writer.write_many(self._lines)
        writer.sync()
        self.notices.append(f"recording deleted: every step so far is saved again in {writer.path.name}")

    def _open(self) -> RecordingWriter:
        if self._writer is None:
            header = self.header.model_copy(update={"created": datetime.now().astimezone()})
            self._writer = RecordingWriter.create_in(self.folder, header)
            self.paths.append(self._writer.path)
        return self._writer


def check_writable(folder: str | Path) -> None:
    """Create `folder` if needed and prove a file can be written in it.

    Raises:
        OSError: the folder cannot be created or written to.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    fd, probe = tempfile.mkstemp(dir=folder, prefix=".careful-probe-")
    os.close(fd)
    os.unlink(probe)


def slug(text: str, *, default: str = "player") -> str:
    """A file-name piece from a name: anything but letters, digits and `_.=-` becomes `_`.

    Used for every file name made from a name (recordings, the fit view's SVG), so a `/` or a
    control character in a name never points a file elsewhere or reaches a terminal.
    """
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", text).strip("_")[:80] or default


# ---------------------------------------------------------------------------- reading

# A longer line is refused before it is parsed (a header with the largest allowed world is far shorter).
MAX_LINE_BYTES = 64 << 20
_BOM = b"\xef\xbb\xbf"


class EmptyRecording(RecordingError):
    """A recording without a single line (what a failed first write used to leave)."""


@dataclass
class Recording:
    """One session file as read: its header, steps, episode ends and any warnings.

    `steps` is a `StepTable`: a sequence of `Step` stored as columns.
    """

    path: Path
    header: SessionHeader
    steps: StepTable = field(default_factory=StepTable)
    episode_ends: list[EpisodeEnd] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def world(self) -> World:
        return self.header.world

    @property
    def episodes(self) -> list[int]:
        """Episode numbers that have a step or an end, in order (the reader checks that order)."""
        ends = np.array([e.episode for e in self.episode_ends], dtype=np.int64)
        return np.union1d(self.steps.column("episode"), ends).tolist()


def read_recording(path: str | Path, *, progress: Callable[[int], None] | None = None) -> Recording:
    """Read and validate one JSONL session file, a line at a time.

    Raises `RecordingError` naming the file, line and field of the first problem (an
    `EmptyRecording` for a file without lines), and for anything that is not a regular file
    (a FIFO is refused, not waited on). A last line cut off without its newline (a crash
    mid-write) is skipped with a warning. `progress` is called with the bytes read since
    its last call, every few thousand lines.
    """
    path = Path(path)
    try:
        file = open_regular(path)
    except OSError as exc:
        raise RecordingError(path, None, None, f"cannot read the file ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise RecordingError(path, None, None, f"is {exc}; a recording is a file") from None
    with file:
        return _read_lines(path, file, progress)


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
            except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
                if not ends_cleanly and recording is not None:
                    recording.warnings.append(f"{path}:{number}: the last line is truncated and was skipped")
                    break
                raise RecordingError(path, number, None, _json_problem(exc)) from None
            if not isinstance(obj, dict):
                raise RecordingError(path, number, None, "a line must be a JSON object")
            if recording is None:
                recording = Recording(path=path, header=_read_header(obj, path, number))
                checker = LineChecker(build_mdp(recording.world))
                continue
            try:
                line = _BODY.validate_python(obj)
            except ValidationError as exc:
                raise _line_error(path, number, exc, obj) from None
        try:
            if isinstance(line, Step):
                checker.step(line, number)
                recording.steps.append(line)
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


def _json_problem(exc: Exception) -> str:
    if isinstance(exc, UnicodeDecodeError):
        return "not UTF-8 text"
    if isinstance(exc, RecursionError):
        return "not valid JSON (arrays or objects nested too deeply)"
    return f"not valid JSON ({exc.msg})"


def _brief(value: Any) -> str:
    """A value from the file, as JSON, short enough for a one-line message."""
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def _read_header(obj: dict, path: Path, number: int) -> SessionHeader:
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
    try:
        return SessionHeader.model_validate(obj)
    except ValidationError as exc:
        raise _line_error(path, number, exc, obj) from None


def _line_error(path: Path, number: int, exc: ValidationError, obj: dict) -> RecordingError:
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
    """

    mdp: MDP
    counts: np.ndarray
    files: int
    episodes: int
    steps: int
    by_episode: sp.csr_matrix | None = None

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
                    f"{printable(world.name, limit=VALUE_LIMIT)!r} (they differ in {differ}): fit recordings of one world at a time",
                )
        mdp = build_mdp(world)
        counts = np.zeros((mdp.n_states, mdp.n_actions))
        index = np.full((world.rows, world.cols), -1, dtype=np.int64)
        for cell, s in mdp.state_of.items():
            index[cell] = s

        def column(name: str) -> np.ndarray:
            return np.concatenate([np.empty(0, np.int64)] + [r.steps.column(name) for r in recordings]).astype(np.int64)

        states = index[column("row"), column("col")]
        actions = column("direction") * world.levels + column("carefulness") - 1
        if states.size:
            np.add.at(counts, (states, actions), 1.0)
        files = np.concatenate([np.empty(0, np.int64)] + [np.full(len(r.steps), i) for i, r in enumerate(recordings)])
        episode_keys = list(zip(files.tolist(), column("episode").tolist()))
        return cls(
            mdp=mdp,
            counts=counts,
            files=len(recordings),
            episodes=sum(len(r.episodes) for r in recordings),
            steps=sum(len(r.steps) for r in recordings),
            by_episode=episode_matrix(episode_keys, states * mdp.n_actions + actions, mdp.n_states * mdp.n_actions),
        )

    @classmethod
    def read(cls, paths: list[str | Path]) -> Demonstrations:
        return cls.from_recordings(read_recordings(paths)[0])

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


def episode_matrix(episode_of_step: list, pair_of_step: np.ndarray, n_pairs: int) -> sp.csr_matrix:
    """(E, n_pairs) per-episode counts: row e counts the pairs (s * A + a) of the e-th distinct episode key.

    Args:
        episode_of_step: (steps,) a hashable episode key per step (e.g. (file, episode)).
        pair_of_step: (steps,) the state-action index s * A + a of each step.
    """
    rows = list(dict.fromkeys(episode_of_step))
    index = {key: e for e, key in enumerate(rows)}
    row_of_step = np.array([index[key] for key in episode_of_step], dtype=np.int64)
    matrix = sp.csr_matrix((np.ones(row_of_step.size), (row_of_step, np.asarray(pair_of_step, dtype=np.int64))),
                           shape=(len(rows), n_pairs))
    matrix.sum_duplicates()
    return matrix
