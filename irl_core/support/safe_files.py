"""Reading only regular files, and one guard for every file a command writes (docs/safety.md).

Reading: a FIFO, a device or a folder given as a world or a recording would block or never
end, so `open_regular` opens without blocking and refuses anything that is not a regular file;
a "regular" file that would still wait for data (`/proc/kmsg`) raises `BlockingIOError` when read.

Writing: no command overwrites a recording or a file it was given to read. Every command that
writes a file (`fit --json/--svg/--figure`, `simulate --out`, `export`, `experiment`) asks
`check_output` first, with the paths it reads; it refuses a path that is one of them (through
links: same device and inode), an existing recording, or anything that is not a regular file.
Every output (`write_output`, export's CSV and Minari dataset, `simulate`) is built under a
hidden temporary name in the destination folder, synced, then renamed into place
(`built_beside`), so a full disk or a kill leaves the old file (or nothing), never half of one.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import io
import json
import os
import re
import secrets
import shutil
import stat
import sys
import tomllib
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from irl_core.errors import OutputError
from irl_core.support.safe_text import printable

# A name careful makes a folder or a file of as it stands (a study's participant, an imported participant's
# recording): no slug can map two names to one path. 1 to 80 letters, digits and `_ . = -`, the first a letter or digit.
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.=-]{0,79}")
SAFE_NAME_RULE = "1 to 80 letters, digits and _ . = -, starting with a letter or digit"

# The longest header line `is_recording` reads (the reader's line limit).
_MAX_HEADER_BYTES = 64 << 20
_SESSION_KIND = re.compile(rb'"kind"\s*:\s*"session"')


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

    def readinto(self, buffer) -> int:
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
    """Why reading an open file failed, for a message (a file that would block says so)."""
    if isinstance(exc, BlockingIOError):
        return "it would wait for data forever, like /proc/kmsg; give a file on disk"
    return exc.strerror or str(exc)


def write_problem(exc: OSError) -> str:
    """Why a write failed, for a message: a full disk (or quota) says "disk full" first."""
    reason = exc.strerror or str(exc)
    return f"disk full: {reason}" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else reason


def reference_problem(name: str) -> str | None:
    """Why `name` cannot be a path on this system (a NUL, a name or path over the system's limits), or None."""
    if "\0" in name:
        return "it holds a NUL character"
    limit = os.pathconf("/", "PC_NAME_MAX") if hasattr(os, "pathconf") else 255
    if any(len(os.fsencode(part)) > limit for part in Path(name).parts):
        return f"a name in it is over the system's {limit} bytes"
    longest = os.pathconf("/", "PC_PATH_MAX") if hasattr(os, "pathconf") else 4096
    if len(os.fsencode(name)) >= longest:
        return f"it is over the system's {longest:,} bytes for a path"
    return None


def read_toml(path: Path, *, what: str, limit: int, too_big: str) -> dict:
    """A TOML file (a world, a study) read whole, if it is a regular file of at most `limit` bytes.

    Args:
        what: "world", "study": the file's kind, for messages ("cannot read the world file").
        too_big: the sentence after "the world file is over N MB; " (what the limit protects).

    Raises:
        ValueError: one line naming `path` and the problem: unreadable, not a regular file, too big,
            not UTF-8, not valid TOML, or a number Python refuses to read (over 4,300 digits).
    """
    try:
        with open_regular(path) as file:
            raw = file.read(limit + 1)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the {what} file ({read_problem(exc)})") from None
    except ValueError as exc:
        raise ValueError(f"{path}: is {exc}; a {what} is a TOML file") from None
    if len(raw) > limit:
        raise ValueError(f"{path}: the {what} file is over {limit >> 20} MB" + (f"; {too_big}" if too_big else ""))
    try:
        return tomllib.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise ValueError(f"{path}: cannot read the {what} file (not UTF-8 text)") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:
        raise ValueError(f"{path}: not valid TOML (arrays or tables nested too deeply)") from None
    except ValueError:
        raise ValueError(f"{path}: a number is over 4,300 digits long") from None


def is_recording(path: str | Path) -> bool:
    """Whether `path` is a regular file whose first line that is not blank is a session header
    (recordings/README.md), read as the reader reads it: however many blank lines come first,
    and wherever in the header `kind` is."""
    try:
        with open_regular(path) as file:
            while line := file.readline(_MAX_HEADER_BYTES):
                if line.lstrip(b"\xef\xbb\xbf").strip():
                    return _is_session_header(line.lstrip(b"\xef\xbb\xbf"))
    except (OSError, ValueError):
        return False
    return False


def _is_session_header(line: bytes) -> bool:
    try:
        header = json.loads(line)
    except (ValueError, RecursionError):
        # A header cut short (a crash mid-write) is still a recording's.
        return line.lstrip().startswith(b"{") and _SESSION_KIND.search(line) is not None
    return isinstance(header, dict) and header.get("kind") == "session"


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


_AT_FDCWD, _RENAME_NOREPLACE = -100, 1


def rename_no_replace(source: str | Path, target: str | Path) -> None:
    """Rename `source` (a file or a folder) to `target`, which must not exist: atomic where the
    system can refuse to replace (Linux's renameat2), else a hard link (files) or a check first.

    Raises:
        FileExistsError: `target` exists (then `source` is left as it was).
    """
    old, new = os.fsencode(source), os.fsencode(target)
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        if hasattr(libc, "renameat2"):
            if libc.renameat2(_AT_FDCWD, old, _AT_FDCWD, new, _RENAME_NOREPLACE) == 0:
                return
            code = ctypes.get_errno()
            if code not in (errno.ENOSYS, errno.EINVAL):
                raise OSError(code, os.strerror(code), os.fsdecode(new))
    if os.path.isdir(old):
        if os.path.lexists(new):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), os.fsdecode(new))
        os.rename(old, new)
        return
    os.link(old, new)  # FileExistsError if it exists
    os.unlink(old)


def _sync_folder(folder: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def sync_tree(path: Path) -> None:
    """fsync every file under `path` (or `path` itself), then the folders, so a rename publishes whole data."""
    if path.is_dir():
        for folder, _, files in os.walk(path):
            for name in files:
                with open(os.path.join(folder, name), "rb") as file:
                    os.fsync(file.fileno())
            _sync_folder(Path(folder))
    else:
        with open(path, "rb") as file:
            os.fsync(file.fileno())


def temporary_name(path: Path) -> Path:
    """A hidden name beside `path` that no one else uses: `.NAME.RANDOM.part`."""
    return path.parent / f".{path.name[:100]}.{secrets.token_hex(6)}.part"


@contextlib.contextmanager
def built_beside(path: str | Path, *, replace: bool = False) -> Iterator[Path]:
    """Build an output under a temporary name beside `path`, then publish it whole.

    Yields the temporary path (not yet created: the caller writes a file or a folder there). When
    the block ends without error, everything there is synced and renamed to `path` in one step,
    over an existing file only with `replace`; on any error (or a kill) `path` is as it was and
    the temporary is removed (after a kill, a hidden `.NAME.*.part` is all that may remain).

    Raises:
        FileExistsError: `path` exists and `replace` is false (the new output is removed).
    """
    path = Path(path)
    temporary = temporary_name(path)
    try:
        yield temporary
        sync_tree(temporary)
        if replace:
            os.replace(temporary, path)
        else:
            rename_no_replace(temporary, path)
        _sync_folder(path.parent)
    finally:
        if temporary.is_dir() and not temporary.is_symlink():
            shutil.rmtree(temporary, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(temporary)


def write_output(path: str | Path, data: str | bytes, *, option: str, inputs: Iterable[str | Path] = ()) -> Path:
    """Check `path` (`check_output`) and write `data` to it whole, or not at all (`built_beside`).

    Raises:
        OutputError: a refused path, or the write failed (full disk, read-only, name too long).
    """
    path = check_output(path, option=option, inputs=inputs)
    payload = data.encode("utf-8") if isinstance(data, str) else data
    try:
        with built_beside(path, replace=True) as temporary, open(temporary, "xb") as file:
            file.write(payload)
    except OSError as exc:
        shown = f"{option} {printable(str(path), limit=160)}"
        raise OutputError(f"{shown}: cannot write the file ({exc.strerror or exc})") from None
    return path
