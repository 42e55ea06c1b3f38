"""One session at a time per participant: a lock that `careful study run` and a web server both take.

Two sessions of one participant at once would play the same block under the same episode
numbers (each number twice, all of them fitted). `participant_lock` holds an exclusive
`flock` on ``<out>/.<ID>.lock`` for as long as the session runs; a second session, in this
process or another, gets `ParticipantBusy` at once, saying who holds it (the holder's words,
its process, host and start time, which the lock file keeps). The kernel drops the lock when
the holder's process ends however it ends, so a crash never leaves a participant locked out.

A web server with several worker processes (`careful serve --workers N`) cannot hold the lock
between a page's requests, which any worker may serve: each worker holds it for one request
(waiting its turn behind the others, `wait_s`), and the page's seat lives in ``<out>/.<ID>.seat``
(`seat_path`). So that a terminal session still never plays a participant whose page plays, the
lock refuses while that file says the seat has played and was heard from within
`SEAT_FRESH_S` (its modification time), unless the web server itself asks (``for_page``).
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import os
import socket
import time
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

from irl_core.errors import ParticipantBusy, StudyError
from irl_core.studies.study import LoadedStudy, check_participant
from irl_core.support.safe_files import write_problem
from irl_core.support.safe_text import printable

_HOLDER_BYTES = 1000
# A page silent this long has left (`careful_tui.web.seats.SILENT_S` is the same: a hidden tab's heartbeat
# may come once a minute).
SEAT_FRESH_S = 90.0
SEAT_PLAYED = b"played\n"
_WAIT_STEP_S = 0.002
_STARTING = "a session that is starting"


def lock_path(study: LoadedStudy, participant: str) -> Path:
    """``<out>/.<ID>.lock``: beside the participant's folder, never counted as one."""
    return study.out / f".{check_participant(participant)}.lock"


def seat_path(study: LoadedStudy, participant: str) -> Path:
    """``<out>/.<ID>.seat``: a web page's seat, while a server with several workers serves it."""
    return study.out / f".{check_participant(participant)}.seat"


@contextlib.contextmanager
def participant_lock(study: LoadedStudy, participant: str, *, holder: str, wait_s: float = 0.0,
                     for_page: bool = False, keep_file: bool = False) -> Iterator[Path]:
    """Hold `participant` of `study` for the block; yields the lock file's path.

    Args:
        holder: who is asking, in words a second session is shown ("careful study run", "the
            web server, browser session 3f2a").
        wait_s: how long to wait while a holder with the same `holder` words has it (another
            request of the same web server); any other holder is refused at once.
        for_page: the web server asks, for a page: a page's seat (`seat_path`) does not refuse it.
        keep_file: leave the lock file when done (a worker's lock for one request: creating and
            removing a file at every request made each episode end's fsync wait on the journal).

    Raises:
        ParticipantBusy: another session holds the participant, or a page plays them.
        StudyError: the participant id is not valid, or the lock cannot be made in ``out``.
    """
    path = lock_path(study, participant)
    if study.out.exists() and not study.out.is_dir():
        raise StudyError(f"{printable(str(study.out))} is a file, not the study's out folder; move it away")
    try:
        study.out.mkdir(parents=True, exist_ok=True)
        fd = _waited(path, participant, holder, wait_s)
    except OSError as exc:
        raise StudyError(f"cannot lock participant {participant} in {printable(str(study.out), limit=160)} "
                         f"({write_problem(exc)}); check the study's out folder") from None
    try:
        since = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
        text = f"{printable(holder, limit=200)} (process {os.getpid()} on {_host()}, since {since})".encode()
        try:
            # A kept file often says this already (the same worker's last request): not written again.
            if not keep_file or os.pread(fd, len(text) + 1, 0) != text:
                os.ftruncate(fd, 0)
                os.pwrite(fd, text, 0)
        except OSError as exc:
            raise StudyError(f"cannot lock participant {participant} in {printable(str(study.out), limit=160)} "
                             f"({write_problem(exc)})") from None
        if not for_page:
            _refuse_seated_page(study, participant)
        yield path
    finally:
        # Removed while still held, so no one can lock the old file after it is gone (see `_locked`).
        if not keep_file:
            with contextlib.suppress(OSError):
                os.unlink(path)
        os.close(fd)


@functools.cache
def _host() -> str:
    return printable(socket.gethostname(), limit=80)


def _refuse_seated_page(study: LoadedStudy, participant: str) -> None:
    """ParticipantBusy while a page of a server with several workers plays `participant` (`seat_path`)."""
    path = seat_path(study, participant)
    try:
        with open(path, "rb") as seat:
            played = seat.read(len(SEAT_PLAYED)) == SEAT_PLAYED
            silent_s = time.time() - os.fstat(seat.fileno()).st_mtime
    except FileNotFoundError:
        return
    except OSError as exc:
        raise StudyError(f"cannot read {printable(str(path), limit=200)} ({write_problem(exc)})") from None
    if played and silent_s < SEAT_FRESH_S:
        raise ParticipantBusy(participant, f"careful serve (a browser page, heard from {max(0.0, silent_s):.0f} s ago)")


def _waited(path: Path, participant: str, holder: str, wait_s: float) -> int:
    """`_locked`, tried again for up to `wait_s` while its holder is one of `holder`'s own (or just starting)."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            return _locked(path, participant)
        except ParticipantBusy as busy:
            ours = busy.holder.startswith(printable(holder, limit=200)) or busy.holder == _STARTING
            if not ours or time.monotonic() >= deadline:
                raise
        time.sleep(_WAIT_STEP_S)


def _locked(path: Path, participant: str) -> int:
    """An open, exclusively locked descriptor of the lock file at `path` (the file that is there now)."""
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, _HOLDER_BYTES, 0).decode("utf-8", "replace").strip() or _STARTING
            os.close(fd)
            raise ParticipantBusy(participant, holder) from None
        except BaseException:
            os.close(fd)
            raise
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)  # the holder removed it between our open and our lock: lock the new one
