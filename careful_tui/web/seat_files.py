"""Seats kept in files: several worker processes of one server (`careful serve --workers N`) serve
any page's request.

A worker holds nothing of a page between its requests. Each request takes the participant's
lock (`irl_core.studies.participant_lock`, waiting its turn behind the server's other requests
for that participant), reads the page's seat from ``<out>/.<ID>.seat``, plays the key on the
session it holds, writes the seat back in place and lets the lock go; every reader of a seat
file holds that lock (or, for the heartbeat, finds a terminal session holding it), so none sees
one half-written. The recordings are written as by one process:
each line appended to the participant's file as it happens, fsynced at each episode end.

A seat file is three text lines and two pickles::

    played            open (no key yet) | played (the page holds the participant) | free
    9f2c...           SHA-256 of the page's secret (the heartbeat checks it without the session)
    5be1...           HMAC-SHA256 of the rest under the server's key
    <pickle>          the length of each recording the session writes, when the seat was written
    <pickle>          page secret, session, key budget

A recording longer than its length there means a worker ended between writing a step and
writing the seat, or could not write the seat (a full disk): the seat is dropped (the page reloads
and resumes where the files say, as after a crash) rather than number a step twice. Every read
checks it, a worker's seat in memory too: the file still holds that worker's MAC when another's
write was lost.

The session is a pickle, read only when its HMAC holds under a key the server draws at its
start (handed to each worker with its settings, never on a command line): a seat file of an earlier run, or one written
by anything else, is never unpickled and counts as no seat. The study, its worlds and the console
travel by name (the worker has its own), a recording's writer by its path (reopened at its next
line), an input mode by its registry name. The file's modification time is when the page was last
heard from: a terminal session is refused while a page that has played was heard from within
`irl_core.studies.participant_lock.SEAT_FRESH_S`.

Bounds, as `careful_tui.web.seats` has them, except that the seats at once are counted from the
files (a seat here holds no file descriptor between requests) and the budget of new pages per client
address lives in one file every worker shares, ``<out>/.pages-by-address``, under an exclusive
`flock` for each new page: one line per address whose budget is not full again, the address's
HMAC under the server's key (never the address itself: a participant's network is not the study's
data), the tokens left and when they were counted (wall clock). A line that does not parse counts
as a full budget.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import hmac
import io
import os
import pickle
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from careful_tui.web.seats import ADDRESS_SEATS, MOST_SEATS, SILENT_S, KeyBudget, Seat, is_page_secret, new_page_secret
from careful_tui.web.session_adapter import WebSession, browser_study
from irl_core.errors import ParticipantBusy, SeatRefused, SeatUnavailable, StudyError
from irl_core.play.input_modes import InputMode, input_mode
from irl_core.recordings.writer import RecordingWriter
from irl_core.studies.participant_lock import SEAT_PLAYED, participant_lock, seat_path
from irl_core.studies.study import LoadedStudy, check_participant

PAGE_HOLDER = "careful serve (a browser page)"
ADDRESS_FILE = ".pages-by-address"
# Another request of the same participant holds the lock for a few milliseconds; a sweep for longer.
LOCK_WAIT_S = 5.0
_OPEN, _FREE = b"open\n", b"free\n"
_HEADER_BYTES = 200


@dataclass
class _Record:
    """A seat file's content: the page's secret (None: free), its session, its key budget."""

    page: str | None
    session: WebSession | None
    tokens: float
    at: float
    played: bool


@dataclass
class _Cached:
    """The seat file a worker wrote last for a participant: its MAC, its record, the record's writers and the
    length of each recording when it was written."""

    mac: bytes
    record: _Record
    writers: list[RecordingWriter]
    sizes: dict[str, int]


class SharedSeats:
    """The pages playing now, one per participant, in the study's out folder (see the module text).

    Args:
        study: the study served (each worker's own, loaded from the same file).
        key: the server's secret for the seat files' HMAC (the same in every worker).
        say: the console's line (travels by name: each worker has its own).
    """

    def __init__(self, study: LoadedStudy, *, key: bytes, say: Callable[[str], None] = print,
                 clock: Callable[[], float] = time.monotonic, wall: Callable[[], float] = time.time,
                 silent_s: float = SILENT_S, limit: int = MOST_SEATS,
                 address_seats: tuple[int, float] = ADDRESS_SEATS) -> None:
        self.study, self.key, self.say = study, key, say
        self.clock, self.wall = clock, wall
        self.silent_s, self.limit, self.address_seats = silent_s, limit, address_seats
        self.browser_study = browser_study(study)
        # participant -> the seat file this worker wrote last: while the file is still that one, the next
        # request skips reading the session back.
        self._cache: dict[str, _Cached] = {}

    # ------------------------------------------------------------------ what the server asks

    def claim(self, participant: str, make_session: Callable[[], WebSession], *, address: str = "",
              hold: object = None) -> Seat | None:
        """A seat for a new page of `participant`, or None while another page of theirs plays (as
        `Seats.claim`; `hold` is not used: the lock is taken here, for the claim).

        Raises:
            SeatRefused: the address opened too many seats of late (429), or every seat is taken (503).
            irl_core.studies.participant_lock.ParticipantBusy: another session plays the participant.
            irl_core.errors.StudyError, OSError: the lock or the seat file cannot be made.
        """
        with self._locked(participant):
            record, seen, writers = self._read(participant)
            try:
                if record is not None and record.page is not None:
                    if self.wall() - seen < self.silent_s:
                        return None
                    self._end(record, "left (the page went silent)")
                    self._write(participant, record)
                if self._seated() >= self.limit:
                    raise SeatRefused(503, "The study is full just now. Please try again in a few minutes.")
                if not self._spend_for(address):
                    raise SeatRefused(429, "Too many pages opened from your network just now. "
                                           "Please try again in a minute.")
                budget = self._budget(record)
                secret = new_page_secret()
                seat = Seat(participant, f"{participant}/{secret}", make_session(), self.clock(), budget,
                            contextlib.nullcontext)
                self._write(participant, _Record(secret, seat.session, budget.tokens, budget.at, False))
            finally:
                _let_go(writers)
            return seat

    def keep_alive(self, page: object) -> bool:
        """The page's heartbeat: whether it holds its seat (its file's time is then now)."""
        parsed = _parse(page)
        if parsed is None:
            return False
        participant, secret = parsed
        try:
            with self._locked(participant):
                return self._touch(participant, secret)
        except ParticipantBusy:  # a terminal session holds the lock: no worker writes the seat meanwhile
            return self._touch(participant, secret)
        except (StudyError, OSError):
            return False

    def _touch(self, participant: str, secret: str) -> bool:
        """Whether the seat file holds `secret`'s page; if so, its time is now."""
        path = seat_path(self.study, participant)
        try:
            with open(path, "rb") as seat:
                state, digest = seat.read(_HEADER_BYTES).split(b"\n")[:2]
            if state + b"\n" == _FREE or not hmac.compare_digest(digest, _digest(secret)):
                return False
            os.utime(path)
        except (OSError, ValueError):
            return False
        return True

    @contextlib.contextmanager
    def playing(self, page: object) -> Iterator[Seat | None]:
        """The seat of `page` for one request, under the participant's lock (None: it holds none); written
        back after, free once its session has left.

        Raises:
            SeatUnavailable: the lock is held elsewhere, or the seat cannot be read or written.
        """
        parsed = _parse(page)
        if parsed is None:
            yield None
            return
        participant, secret = parsed
        with contextlib.ExitStack() as held:
            try:
                held.enter_context(self._locked(participant))
            except (StudyError, OSError) as exc:
                raise SeatUnavailable(participant, exc) from None
            record, seen, writers = self._read(participant)
            if record is None or record.page is None or record.session is None \
                    or not hmac.compare_digest(record.page.encode(), secret.encode()):
                yield None
                return
            budget = self._budget(record)
            seat = Seat(participant, f"{participant}/{secret}", record.session, seen, budget, contextlib.nullcontext,
                        locked=record.played)
            try:
                yield seat
            finally:
                if seat.session.left:
                    record.page, record.session = None, None
                record.tokens, record.at, record.played = budget.tokens, budget.at, seat.locked
                try:
                    self._write(participant, record)
                except OSError as exc:  # a full disk: the key was played and recorded, its seat not kept
                    raise SeatUnavailable(participant, exc) from None
                finally:
                    _let_go(writers)

    def leave(self, page: object, why: str) -> None:
        """The page closed: its seat, if it holds one, is released."""
        with contextlib.suppress(SeatUnavailable), self.playing(page) as seat:
            if seat is not None:
                seat.session.leave(why)

    def release_silent(self) -> None:
        """Release every page not heard from for `silent_s`, and forget seat files older than that."""
        for path, _ in self._files():
            self._sweep(path, "left (the page went silent)", only_silent=True)

    def release_all(self, why: str) -> None:
        """Every page leaves (the server stops): sessions record what was running; the files go."""
        for path, _ in self._files():
            self._sweep(path, why, only_silent=False)

    def __len__(self) -> int:
        return self._seated()

    # ------------------------------------------------------------------ the files

    def _locked(self, participant: str) -> contextlib.AbstractContextManager[Path]:
        return participant_lock(self.study, participant, holder=PAGE_HOLDER, wait_s=LOCK_WAIT_S, for_page=True,
                                keep_file=True)

    def _sweep(self, path: Path, why: str, *, only_silent: bool) -> None:
        participant = path.name[1:-len(".seat")]
        try:
            check_participant(participant)
            with self._locked(participant):
                if only_silent and self.wall() - path.stat().st_mtime < self.silent_s:
                    return
                record, _, writers = self._read(participant)
                try:
                    if record is not None and record.session is not None:
                        self._end(record, why)
                finally:
                    _let_go(writers)
                path.unlink()
                self._cache.pop(participant, None)
        except FileNotFoundError:
            return  # another worker swept it
        except (StudyError, OSError) as exc:  # a terminal session holds them, a full disk: the next sweep
            self.say(f"{participant}: seat not released yet ({exc})")

    def _end(self, record: _Record, why: str) -> None:
        assert record.session is not None
        record.session.leave(why)
        record.page, record.session = None, None

    def _budget(self, record: _Record | None) -> KeyBudget:
        budget = KeyBudget(clock=self.clock)
        if record is not None:
            budget.tokens, budget.at = record.tokens, record.at
        return budget

    def _spend_for(self, address: str) -> bool:
        """Whether `address` may open a new page now (its budget spent by one), counted across the workers in
        ``<out>/.pages-by-address`` (see the module text); budgets full again are dropped from the file."""
        burst, rate = self.address_seats
        name = hmac.new(self.key, address.encode("utf-8", "replace"), hashlib.sha256).hexdigest()[:32]
        fd = os.open(self.study.out / ADDRESS_FILE, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o600)
        with os.fdopen(fd, "r+b") as file:
            fcntl.flock(file, fcntl.LOCK_EX)
            budgets: dict[str, KeyBudget] = {}
            for line in file.read().decode("ascii", "replace").splitlines():
                with contextlib.suppress(ValueError):
                    key, tokens, at = line.split(" ")
                    budgets[key] = KeyBudget(burst=burst, rate=rate, clock=self.wall)
                    budgets[key].tokens, budgets[key].at = float(tokens), float(at)
            spent = budgets.setdefault(name, KeyBudget(burst=burst, rate=rate, clock=self.wall)).spend()
            kept = "".join(f"{key} {budget.tokens!r} {budget.at!r}\n" for key, budget in budgets.items()
                           if not budget.full())
            file.seek(0)
            file.write(kept.encode("ascii"))
            file.truncate()
        return spent

    def _files(self) -> list[tuple[Path, bytes]]:
        """Every seat file with its first line."""
        found = []
        for path in self.study.out.glob(".*.seat"):
            with contextlib.suppress(OSError), open(path, "rb") as seat:
                found.append((path, seat.readline()))
        return found

    def _seated(self) -> int:
        return sum(state != _FREE for _, state in self._files())

    def _read(self, participant: str) -> tuple[_Record | None, float, list[RecordingWriter]]:
        """The participant's seat (None: no file, or one this server did not write), when it was last heard
        from (wall clock), and the recording writers its session holds (to let go after the request)."""
        try:
            with open(seat_path(self.study, participant), "rb") as seat:
                data, seen = seat.read(), os.fstat(seat.fileno()).st_mtime
        except FileNotFoundError:
            return None, 0.0, []
        parts = data.split(b"\n", 3)
        if len(parts) != 4:
            return None, seen, []
        # When this worker wrote it last, its session is the one in memory, and so are the lengths it saw.
        cached = self._cache.get(participant)
        if cached is not None and not hmac.compare_digest(parts[2], cached.mac):
            cached = None  # another worker wrote it since
        if cached is None and not hmac.compare_digest(parts[2], self._mac(parts[0], parts[1], parts[3])):
            return None, seen, []
        stream = io.BytesIO(parts[3])
        sizes = cached.sizes if cached is not None else pickle.load(stream)
        # Checked on every read, the cached seat's too: another worker may have appended a step since and
        # ended (or found the disk full) before writing the seat, which still holds this worker's MAC.
        if any(_size(path) > size for path, size in sizes.items()):
            # The session would number its next step again. The page reloads instead, and resumes where the
            # files say (as after a crash).
            self._cache.pop(participant, None)
            self.say(f"{participant}: the page's seat was behind its recording (a worker stopped mid-request, "
                     "or its seat could not be written); the page starts again from the files")
            return None, seen, []
        if cached is not None:
            return cached.record, seen, cached.writers
        loader = _SessionUnpickler(stream, self)
        fields = loader.load()
        return _Record(**fields), seen, loader.writers

    def _write(self, participant: str, record: _Record) -> None:
        """The seat file, written over the old in place (under the participant's lock)."""
        state = _FREE if record.page is None else SEAT_PLAYED if record.played else _OPEN
        digest = b"-" if record.page is None else _digest(record.page)
        body = io.BytesIO()
        pickler = _SessionPickler(body, self, record.session)
        pickler.dump({"page": record.page, "session": record.session, "tokens": record.tokens, "at": record.at,
                      "played": record.played})
        # First the length of each recording the session writes, to tell a seat older than its files (`_read`).
        sizes = {str(writer.path): _size(writer.path) for writer in pickler.writers if writer.is_open}
        data = pickle.dumps(sizes, protocol=pickle.HIGHEST_PROTOCOL) + body.getvalue()
        mac = self._mac(state[:-1], digest, data)
        self._cache.pop(participant, None)
        try:
            # Written in place, under the lock every reader takes: a new file renamed over the old at every
            # request made each episode end's fsync wait on the journal (p99 0.7 s at 200 participants).
            # A crash mid-write leaves a file whose HMAC fails: no seat, the page reloads; its steps are on disk.
            fd = os.open(seat_path(self.study, participant), os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0),
                         0o600)
            try:
                whole = state + digest + b"\n" + mac + b"\n" + data
                view = memoryview(whole)
                while view:
                    view = view[os.pwrite(fd, view, len(whole) - len(view)):]
                os.ftruncate(fd, len(whole))
            finally:
                os.close(fd)
        finally:
            _let_go(pickler.writers)
        if record.page is not None:
            self._cache[participant] = _Cached(mac, record, pickler.writers, sizes)

    def _mac(self, state: bytes, digest: bytes, body: bytes) -> bytes:
        return hmac.new(self.key, state + b"\n" + digest + b"\n" + body, hashlib.sha256).hexdigest().encode()


def _size(path: str | Path) -> int:
    """The file's length, or -1 when it is gone (its recorder saves its lines again: `RecordingLost`)."""
    try:
        return os.stat(path).st_size
    except FileNotFoundError:
        return -1


def _digest(secret: str) -> bytes:
    return hashlib.sha256(secret.encode()).hexdigest().encode()


def _parse(page: object) -> tuple[str, str] | None:
    """A page id, ``<participant>/<secret>``, as its two parts (None: not one, whatever it holds)."""
    if not isinstance(page, str) or len(page) > 200:
        return None
    participant, _, secret = page.partition("/")
    try:
        check_participant(participant)
    except StudyError:
        return None
    return (participant, secret) if is_page_secret(secret) else None


def _let_go(writers: list[RecordingWriter]) -> None:
    """Close the descriptors a request's writers opened (no fsync: each episode end had one); the next line
    opens the file again."""
    for writer in writers:
        writer.detach()


class _SessionPickler(pickle.Pickler):
    """Pickles a seat, with what every worker has by name (see the module text)."""

    def __init__(self, file: io.BytesIO, seats: SharedSeats, session: WebSession | None) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.writers: list[RecordingWriter] = []
        known: dict[int, Any] = {id(seats.study): "study", id(seats.say): "say"}
        known.update({id(world): ("world", i) for i, world in enumerate(seats.study.worlds)})
        if session is not None:
            known.update({id(session.study): "browser_study", id(session.say): "say"})
        self.known = known

    def persistent_id(self, obj: Any) -> Any:
        name = self.known.get(id(obj))
        if name is not None:
            return name
        if isinstance(obj, RecordingWriter):
            self.writers.append(obj)
            return ("writer", str(obj.path), obj.is_open, obj.sync_episodes)
        if isinstance(obj, InputMode):
            return ("input_mode", obj.name)
        return None


class _SessionUnpickler(pickle.Unpickler):
    """Reads what `_SessionPickler` wrote, with this worker's study, worlds, console and writers."""

    def __init__(self, file: io.BytesIO, seats: SharedSeats) -> None:
        super().__init__(file)
        self.seats = seats
        self.writers: list[RecordingWriter] = []

    def persistent_load(self, pid: Any) -> Any:
        seats = self.seats
        if pid == "study":
            return seats.study
        if pid == "browser_study":
            return seats.browser_study
        if pid == "say":
            return seats.say
        kind, *rest = pid
        if kind == "world":
            return seats.study.worlds[rest[0]]
        if kind == "writer":
            path, is_open, sync_episodes = rest
            writer = RecordingWriter.reopened(path, sync_episodes=sync_episodes, is_open=is_open)
            self.writers.append(writer)
            return writer
        if kind == "input_mode":
            return input_mode(rest[0])
        raise pickle.UnpicklingError(f"unknown persistent id {pid!r}")
