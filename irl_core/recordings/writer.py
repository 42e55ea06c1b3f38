"""Writing recordings (recordings/README.md): a crash-safe writer, a game's session recorder, file names.

`RecordingWriter` never overwrites, flushes every line and fsyncs at each episode end, so a
crash loses at most the line in flight; it never leaves an empty file, and never writes a
number JSON cannot hold. `SessionRecorder` is what `careful play` writes through: it names the
file by time and player at the first line and saves a session again when its file is deleted
mid-play. `irl_core.recordings.demonstrations` reads what these write.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Callable, Iterable
from datetime import datetime
from pathlib import Path

from irl_core.errors import RecordingLost
from irl_core.recordings.lines import CalibrationTrial, EpisodeEnd, SessionHeader, Step, _Line
from irl_core.recordings.reach_lines import ReachHeader, ReachStep

BodyLine = Step | EpisodeEnd | CalibrationTrial | ReachStep


def to_json_line(line: _Line) -> str:
    """One JSONL line (with its newline) in the recording format's field names.

    Raises:
        ValueError: a number JSON cannot hold (NaN, Infinity); nothing is written for it.
    """
    data = line.model_dump(mode="json", by_alias=True)
    for optional in ("realised", "study", "prolific", "bin", "input"):
        if data.get(optional, "") is None:
            del data[optional]
    return json.dumps(data, ensure_ascii=False, allow_nan=False) + "\n"


def _encoded(line: _Line) -> bytes:
    """`to_json_line` as UTF-8; a name holding undecodable bytes is a `ValueError`, raised before any write."""
    try:
        return to_json_line(line).encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("a name holds bytes that are not UTF-8 text") from None


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

    def __init__(self, path: str | Path, header: SessionHeader | ReachHeader, *, sync_episodes: bool = True):
        self.path = Path(path)
        self._sync_episodes = sync_episodes
        first = _encoded(header)
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND | getattr(os, "O_CLOEXEC", 0)
        self._fd: int | None = os.open(self.path, flags, 0o666)
        self._reopen = False
        try:
            self._write_bytes(first)
            self.sync()
        except BaseException:
            self._discard()
            raise

    @classmethod
    def reopened(cls, path: str | Path, *, sync_episodes: bool = True, is_open: bool = True) -> RecordingWriter:
        """A writer that goes on appending to the existing file at `path`, opened at its next write
        (a web server's worker process takes up a session another one wrote: `careful_tui.web.seat_files`).
        A file gone by then is `RecordingLost` at that write, as for a file deleted mid-write.
        `is_open=False` gives a closed writer (its writes refused, as after `close`)."""
        writer = cls.__new__(cls)
        writer.path, writer._sync_episodes = Path(path), sync_episodes
        writer._fd, writer._reopen = None, is_open
        return writer

    @property
    def is_open(self) -> bool:
        """Whether lines may still be written (it is not closed)."""
        return self._fd is not None or self._reopen

    @property
    def sync_episodes(self) -> bool:
        return self._sync_episodes

    @classmethod
    def create_in(cls, folder: str | Path, header: SessionHeader | ReachHeader) -> RecordingWriter:
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
        self.write_encoded(_encoded(step))

    def end_episode(self, end: EpisodeEnd) -> None:
        self.write_encoded(_encoded(end), episode_end=True)

    def write_trial(self, trial: CalibrationTrial) -> None:
        """A calibration trial, synced at once: a participant's trial is not asked twice."""
        self.write_encoded(_encoded(trial), now=True)

    def write_encoded(self, data: bytes, *, episode_end: bool = False, now: bool = False) -> None:
        """Lines already encoded (`_encoded`), synced `now`, or at an `episode_end` unless `sync_episodes` is off."""
        self._write_bytes(data)
        if now or (episode_end and self._sync_episodes):
            self.sync()

    def write_many(self, lines: Iterable[BodyLine]) -> None:
        """Several lines in one write (bulk output): encoded first, so a bad one writes nothing."""
        self._write_bytes(b"".join(_encoded(line) for line in lines))

    def close(self) -> None:
        if self._reopen:
            self._descriptor()
        if self._fd is not None:
            try:
                self.sync()
            finally:
                os.close(self._fd)
                self._fd = None

    def abandon(self) -> None:
        """Close without syncing (the file is gone or cannot be written; or, for a `reopened` writer, another
        process goes on with it)."""
        self._reopen = False
        if self._fd is not None:
            try:
                os.close(self._fd)
            except OSError:
                pass
            self._fd = None

    def detach(self) -> None:
        """Close the descriptor without syncing; the next line opens the file again (a web server's worker lets
        it go between requests: `careful_tui.web.seat_files`)."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            self._reopen = True
            os.close(fd)

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _write_bytes(self, data: bytes) -> None:
        fd = self._descriptor()
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
        if os.fstat(fd).st_nlink == 0:
            raise RecordingLost(f"{self.path} was deleted while it was being written")

    def sync(self) -> None:
        """Flush the file to disk."""
        fd = self._descriptor()
        os.fsync(fd)
        if os.fstat(fd).st_nlink == 0:
            raise RecordingLost(f"{self.path} was deleted while it was being written")

    def _descriptor(self) -> int:
        """The open file; a `reopened` writer opens its file here, never creating it."""
        if self._fd is None and self._reopen:
            self._reopen = False
            try:
                self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | getattr(os, "O_CLOEXEC", 0))
            except FileNotFoundError:
                raise RecordingLost(f"{self.path} was deleted while it was being written") from None
        if self._fd is None:
            raise ValueError(f"{self.path} is closed")
        return self._fd

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

    def __init__(self, folder: str | Path, header: SessionHeader | ReachHeader) -> None:
        self.folder = Path(folder)
        self.header = header
        self.paths: list[Path] = []
        self.lost: list[Path] = []
        self.notices: list[str] = []
        self._writer: RecordingWriter | None = None
        # The file's lines, encoded in one buffer: a session taken up by another process pickles it at once.
        self._lines = bytearray()

    @property
    def path(self) -> Path | None:
        """The file being written, or None before the first line (or after a header change)."""
        return None if self._writer is None else self._writer.path

    def set_header(self, header: SessionHeader | ReachHeader) -> None:
        self.close()
        self.header = header

    def write_step(self, step: Step) -> None:
        self._record(step, lambda writer: writer.write_step(step))

    def end_episode(self, end: EpisodeEnd) -> None:
        self._record(end, lambda writer: writer.end_episode(end))

    def write_trial(self, trial: CalibrationTrial) -> None:
        self._record(trial, lambda writer: writer.write_trial(trial))

    def write_reach(self, step: ReachStep) -> None:
        """A reach trial, synced at once as an episode's end is: a trial is an episode (docs/reach.md)."""
        self._record(step, lambda writer: writer.write_encoded(_encoded(step), episode_end=True))

    def close(self) -> None:
        if self._writer is None:
            return
        try:
            self._writer.close()
        except RecordingLost:
            self._recover()
            self._writer.close()
        self._writer = None
        self._lines = bytearray()

    def _record(self, line: BodyLine, write: Callable[[RecordingWriter], None]) -> None:
        encoded = _encoded(line)  # first: a line that cannot be encoded is refused before anything is kept
        self._lines += encoded
        try:
            write(self._open())
        except RecordingLost:
            self._recover()
        except BaseException:
            del self._lines[len(self._lines) - len(encoded):]
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
        writer.write_encoded(bytes(self._lines))
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
