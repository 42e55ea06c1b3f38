"""One `careful serve` per out folder, whatever its number of workers.

Two servers on one out folder would each take the other's pages for strangers: with several
workers, the second cannot verify the first's seat files (each server signs them with a key of its
own), reads them as no seat, writes over them (a second page for one participant) and deletes them
when it stops. So a server holds an exclusive `flock` on ``<out>/.serving`` from before it writes
anything there (links, seats) until its last process ends; a second server is refused at once, in
one line that names the holder (the lock file keeps its process, host, start time and address).

Each worker holds the lock too (its descriptor is handed to the worker as it starts): a server whose
parent was killed outright keeps the folder until its workers have released their seats. The
kernel drops the lock when the last holder ends however it ends; the file stays (a few bytes, never
read as a participant: ``.serving`` is no participant id's lock or seat).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import socket
from datetime import UTC, datetime
from multiprocessing.reduction import DupFd
from pathlib import Path
from typing import Any

from irl_core.errors import UsageError
from irl_core.studies.study import LoadedStudy
from irl_core.support.safe_files import write_problem
from irl_core.support.safe_text import printable

SERVING_FILE = ".serving"
_HOLDER_BYTES = 1000


class ServingLock:
    """The out folder's lock, held while the descriptor `fd` is open in any process of the server.

    Pickled to a worker as it starts (multiprocessing's spawn), it arrives as a duplicate of the
    descriptor, which holds the same lock.
    """

    def __init__(self, fd: int, path: Path) -> None:
        self.fd, self.path = fd, path

    def __reduce__(self) -> tuple[Any, ...]:
        # Only while a process is being started: DupFd passes the descriptor to it (`multiprocessing.reduction`).
        return _received, (DupFd(self.fd), self.path)

    def name_address(self, address: str) -> None:
        """Say where this server listens, for a second server's refusal."""
        self._write_holder(f", at {printable(address, limit=100)}")

    def release(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self.fd)

    def _write_holder(self, more: str = "") -> None:
        since = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
        text = f"careful serve (process {os.getpid()} on {printable(socket.gethostname(), limit=80)}, since {since}{more})"
        try:
            os.ftruncate(self.fd, 0)
            os.pwrite(self.fd, text.encode(), 0)
        except OSError as exc:
            raise UsageError(f"cannot write {printable(str(self.path), limit=200)} ({write_problem(exc)}); "
                             "check the study's out folder") from None


def _received(dup: Any, path: Path) -> ServingLock:
    return ServingLock(dup.detach(), path)


def hold_out_folder(study: LoadedStudy) -> ServingLock:
    """Take `study`'s out folder for this server (`ServingLock.release` lets it go).

    Raises:
        UsageError: another server holds it (naming that server), or the lock cannot be made there.
    """
    path = study.out / SERVING_FILE
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
    except OSError as exc:
        raise UsageError(f"cannot write {printable(str(path), limit=200)} ({write_problem(exc)}); "
                         "check the study's out folder") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.pread(fd, _HOLDER_BYTES, 0).decode("utf-8", "replace").strip() or "a server that is starting"
        os.close(fd)
        raise UsageError(f"{printable(str(study.out), limit=200)} is served already by {printable(holder, limit=300)}; "
                         "stop that server first, or give this study another out folder") from None
    held = ServingLock(fd, path)
    try:
        held._write_holder()
    except UsageError:
        held.release()
        raise
    return held
