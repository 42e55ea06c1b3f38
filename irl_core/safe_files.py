"""Reading only regular files, and one guard for every file a command writes (README "Limits and safety").

Reading: a FIFO, a device or a folder given as a world or a recording would block or never
end, so `open_regular` opens without blocking and refuses anything that is not a regular file;
a "regular" file that would still wait for data (`/proc/kmsg`) raises `BlockingIOError` when read.

Writing: no command overwrites a recording or a file it was given to read. Every command that
writes a file (`fit --json/--svg/--figure`, `simulate --out`, `export`, `experiment`) asks
`check_output` first, with the paths it reads; it refuses a path that is one of them (through
links: same device and inode), an existing recording, or anything that is not a regular file.
`write_output` then writes the new content beside the target and renames it into place, so a
full disk leaves the old file (or nothing), never half a file.
"""

from __future__ import annotations

import errno
import io
import os
import re
import stat
import tempfile
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import BinaryIO

from irl_core.safe_text import printable

# How much of a file's start `is_recording` reads: a session header holds its whole world.
_SNIFF_BYTES = 1 << 16
_SESSION_KIND = re.compile(rb'"kind"\s*:\s*"session"')


class InputError(ValueError):
    """A file or a name a command was given that cannot be used: a recording, a world, a study.

    Every reader raises its own subclass (`RecordingError`, `WorldError`, `StudyError`) for every
    problem of what it reads, and nothing else, so that a caller who catches this one type never
    lets one bad file stop a command (or a study's other participants). The message is one line.
    """


class OutputError(ValueError):
    """An output path a command must not write, or could not write; the message is one line."""


def describe_kind(mode: int) -> str:
    """What a non-regular file is, for messages: "a FIFO", "a folder", ..."""
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


class _NeverWaiting(io.FileIO):
    """A file read without blocking: a read that would wait raises instead of returning None."""

    def readinto(self, buffer) -> int:  # type: ignore[override]
        count = super().readinto(buffer)
        if count is None:
            raise BlockingIOError(errno.EAGAIN, "the file would wait for data")
        return count


def open_regular(path: str | Path) -> BinaryIO:
    """Open `path` for binary reading if it is a regular file.

    The file stays non-blocking (files on disk ignore that): a pseudo file that waits for data,
    such as `/proc/kmsg`, raises `BlockingIOError` on the read that would wait.

    Raises:
        OSError: the file cannot be opened (missing, no permission).
        ValueError: it is a FIFO, a device, a folder or a socket (the message says which);
            a FIFO is opened without blocking, so no writer is waited for.
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise ValueError(f"{describe_kind(mode)}, not a regular file")
        return io.BufferedReader(_NeverWaiting(fd, "rb"))
    except BaseException:
        os.close(fd)
        raise


def read_problem(exc: OSError) -> str:
    """Why reading an open file failed, for a message: a file that would block  says so."""
    if isinstance(exc, BlockingIOError):
        return "it would wait for data forever, like /proc/kmsg; give a file on disk"
    return exc.strerror or str(exc)


def reference_problem(name: str) -> str | None:
    """Why `name` cannot be a path on this system (a NUL, a name or path over the system's limits), or None."""
    if "\0" in name:
        return "it holds a NUL character"
    limit = os.pathconf("/", "PC_NAME_MAX") if hasattr(os, "pathconf") else 255
    if any(len(os.fsencode(part)) > limit for part in Path(name).parts):
        return f"a name in it is over the system's {limit} bytes"
    if len(os.fsencode(name)) >= 4096:
        return "it is over the system's 4,096 bytes for a path"
    return None


def parse_toml(raw: bytes) -> dict:
    """A TOML file's bytes as a table.

    Raises:
        ValueError: one phrase for a message: "not UTF-8 text", "not valid TOML (...)", or the
            number that is too long (Python refuses to read integers of over 4,300 digits).
    """
    try:
        return tomllib.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise ValueError("not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"not valid TOML ({exc})") from None
    except RecursionError:
        raise ValueError("not valid TOML (arrays or tables nested too deeply)") from None
    except ValueError:
        raise ValueError("not valid TOML here (a number is over 4,300 digits long)") from None


def is_recording(path: str | Path) -> bool:
    """Whether `path` is a regular file whose first line is a session header (recordings/README.md)."""
    try:
        with open_regular(path) as file:
            head = file.read(_SNIFF_BYTES)
    except (OSError, ValueError):
        return False
    first = head.lstrip(b"\xef\xbb\xbf \t\r\n").split(b"\n", 1)[0]
    return first.startswith(b"{") and _SESSION_KIND.search(first) is not None


def _same_file(a: os.stat_result, b: os.stat_result) -> bool:
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def check_output(path: str | Path, *, option: str, inputs: Iterable[str | Path] = ()) -> Path:
    """Refuse an output path that would destroy data or cannot be a file; return it.

    Refused: a missing parent folder; a link to nothing; an existing path that is not a
    regular file; any of `inputs` (after links: the same device and inode); an existing
    recording. An existing regular file that is none of these (an earlier --json) may be
    replaced.

    Raises:
        OutputError: one line naming `option`, the path and the reason.
    """
    path = Path(path)
    shown = f"{option} {printable(str(path), limit=160)}"
    parent = path.parent
    if not parent.is_dir():
        raise OutputError(f"{shown}: the folder {printable(str(parent), limit=160)} does not exist; create it first")
    try:
        target = os.stat(path)
    except FileNotFoundError:
        if path.is_symlink():
            raise OutputError(f"{shown}: is a link to nothing; give the path of a new file") from None
        return path
    except OSError as exc:
        raise OutputError(f"{shown}: cannot use this path ({exc.strerror or exc})") from None
    if not stat.S_ISREG(target.st_mode):
        raise OutputError(f"{shown}: is {describe_kind(target.st_mode)}; give the path of a new file")
    for source in inputs:
        try:
            if _same_file(target, os.stat(source)):
                raise OutputError(f"{shown}: is a file this command reads, and would be overwritten; "
                                  "choose another path")
        except OSError:
            continue
    if is_recording(path):
        raise OutputError(f"{shown}: is a recording, and recordings are never overwritten; choose another path")
    return path


def check_output_folder(folder: str | Path, *, option: str) -> Path:
    """Refuse an output folder that exists as something else (a file, a FIFO); return it."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        what = "a file" if folder.is_file() else describe_kind(os.stat(folder).st_mode)
        raise OutputError(f"{option} {printable(str(folder), limit=160)}: is {what}, not a folder; choose a folder")
    if folder.is_symlink() and not folder.exists():
        raise OutputError(f"{option} {printable(str(folder), limit=160)}: is a link to nothing; choose a folder")
    return folder


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_output(path: str | Path, data: str | bytes, *, option: str, inputs: Iterable[str | Path] = ()) -> Path:
    """Check `path` (`check_output`) and write `data` to it whole, or not at all.

    The data goes to a temporary file in the same folder, is synced, and is renamed over
    `path`; on any error the temporary file is removed and `path` is as it was.

    Raises:
        OutputError: a refused path, or the write failed (full disk, read-only, name too long).
    """
    path = check_output(path, option=option, inputs=inputs)
    payload = data.encode("utf-8") if isinstance(data, str) else data
    shown = f"{option} {printable(str(path), limit=160)}"
    temporary = None
    try:
        fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:100]}.", suffix=".part")
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as file:
            file.write(payload)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
        temporary = None
    except OSError as exc:
        raise OutputError(f"{shown}: cannot write the file ({exc.strerror or exc})") from None
    finally:
        if temporary is not None:
            try:
                os.unlink(temporary)
            except OSError:
                pass
    return path
