"""One page per participant, and a bound on how fast a page may send keys.

A participant plays on one page at a time: a second tab or device that opens their link while the
first is open is refused (never interleaved into the same file). A page holds its seat while it
is heard from (every key, and a heartbeat every few seconds); one that closes says so
(`navigator.sendBeacon`), and one silent for `SILENT_S` has left: its seat goes to the next page
that asks. From its first key a seat holds the participant's lock (`irl_core.studies.participant_lock`,
the one `careful study run` takes), so a terminal session and a page never play one participant
at once, in this process or another; before it, a seat holds no file (a page that is opened and
never played costs no file descriptor), and the lock is only tried, to say at once when another
session holds it.

Bounds, so no one page, participant or address can take the server for itself:

- `KeyBudget`, a token bucket per participant (not per page: a new page does not refill it):
  `KEY_BURST` key events at once, then `KEY_RATE` a second (four moves a second sustained is
  more than a person makes, holding a key for each);
- new seats per client address: `ADDRESS_SEATS` (a burst, then a rate: a lab behind one address
  starts its participants at once, an invented id a second is all one address gets beyond);
- seats at once: `limit` (`seat_limit`: a share of the process's open-file limit, as a playing
  seat holds two files, its lock and its recording).
"""

from __future__ import annotations

import contextlib
import re
import resource
import secrets
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import TypeGuard

from careful_tui.web.session_adapter import WebSession
from irl_core.errors import SeatRefused
from irl_core.studies.participant_lock import SEAT_FRESH_S

# A hidden tab's timers may run once a minute (Chrome's intensive throttling): its heartbeat still arrives.
SILENT_S = SEAT_FRESH_S
KEY_BURST = 24
KEY_RATE = 12.0
ADDRESS_SEATS = (120, 1.0)
MOST_SEATS = 1000
FILES_PER_SEAT = 2
FILES_KEPT = 64  # the server's own: its sockets, the package's files, the log
# A page's secret is `secrets.token_urlsafe(PAGE_SECRET_BYTES)`; whatever else a request sends as one (text
# no secret holds, é, a lone surrogate) is no page's, refused where it arrives (`is_page_secret`).
PAGE_SECRET_BYTES = 18
_PAGE_SECRET = re.compile(r"[A-Za-z0-9_-]{24}")  # 18 bytes in URL-safe base64


def new_page_secret() -> str:
    return secrets.token_urlsafe(PAGE_SECRET_BYTES)


def is_page_secret(text: object) -> TypeGuard[str]:
    """Whether `text` has the shape of a page's secret (`new_page_secret`)."""
    return isinstance(text, str) and _PAGE_SECRET.fullmatch(text) is not None


def seat_limit() -> int:
    """How many seats may play at once: what the open-file limit leaves, at most `MOST_SEATS`."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    # Half the room for seats, half for connections (`careful_tui.commands.serve.connection_limit`).
    room = MOST_SEATS if soft == resource.RLIM_INFINITY else (soft - FILES_KEPT) // (2 * FILES_PER_SEAT)
    return max(1, min(MOST_SEATS, room))


class KeyBudget:
    """A token bucket: `spend` is True while the page keeps within `burst` events and `rate` a second."""

    def __init__(self, *, burst: int = KEY_BURST, rate: float = KEY_RATE, clock: Callable[[], float] = time.monotonic):
        self.burst, self.rate, self.clock = burst, rate, clock
        self.tokens = float(burst)
        self.at = clock()

    def spend(self) -> bool:
        self._refill()
        if self.tokens < 1:
            return False
        self.tokens -= 1
        return True

    def full(self) -> bool:
        """Whether the bucket is back to its burst (it can be forgotten: a new one is the same)."""
        self._refill()
        return self.tokens >= self.burst

    def _refill(self) -> None:
        now = self.clock()
        self.tokens = min(self.burst, self.tokens + (now - self.at) * self.rate)
        self.at = now


@dataclass
class Seat:
    """A participant's page: its unguessable id, its session, when it was last heard from, and
    `hold`, which makes the participant's lock (taken by `take_lock` at the first key)."""

    participant: str
    page: str
    session: WebSession
    seen: float
    budget: KeyBudget
    hold: Callable[[], AbstractContextManager[object]]
    held: contextlib.ExitStack = field(default_factory=contextlib.ExitStack)
    locked: bool = False
    lock: threading.Lock = field(default_factory=threading.Lock)

    def take_lock(self) -> None:
        """Hold the participant's lock from now until the seat is released (once; call under `lock`).

        Raises:
            irl_core.studies.participant_lock.ParticipantBusy: another session took it meanwhile.
            irl_core.errors.StudyError: it cannot be made (a full disk).
        """
        if not self.locked:
            self.held.enter_context(self.hold())
            self.locked = True


class Seats:
    """The pages playing now, one per participant."""

    def __init__(self, *, clock: Callable[[], float] = time.monotonic, silent_s: float = SILENT_S,
                 limit: int | None = None, address_seats: tuple[int, float] = ADDRESS_SEATS) -> None:
        self.clock = clock
        self.silent_s = silent_s
        self.limit = seat_limit() if limit is None else limit
        self.address_seats = address_seats
        self._lock = threading.Lock()
        self._pages: dict[str, Seat] = {}
        self._participants: dict[str, Seat] = {}
        self._budgets: dict[str, KeyBudget] = {}
        self._addresses: dict[str, KeyBudget] = {}

    def claim(self, participant: str, make_session: Callable[[], WebSession], *, address: str = "",
              hold: Callable[[], AbstractContextManager[object]] = contextlib.nullcontext) -> Seat | None:
        """A seat for a new page of `participant` from client `address`, or None while another page
        of theirs plays.

        `hold` makes the participant's lock: tried now (and let go), held from the seat's first key.

        Raises:
            SeatRefused: the address opened too many seats of late (429), or every seat is taken (503).
            irl_core.studies.participant_lock.ParticipantBusy: another process plays the participant.
        """
        with self._lock:
            held = self._participants.get(participant)
            if held is not None:
                if self.clock() - held.seen < self.silent_s:
                    return None
                self._release(held, "left (the page went silent)")
            if len(self._pages) >= self.limit:
                raise SeatRefused(503, "The study is full just now. Please try again in a few minutes.")
            burst, rate = self.address_seats
            if not self._addresses.setdefault(address, KeyBudget(burst=burst, rate=rate, clock=self.clock)).spend():
                raise SeatRefused(429, "Too many pages opened from your network just now. Please try again in a minute.")
            with hold():
                pass
            session = make_session()
            budget = self._budgets.setdefault(participant, KeyBudget(clock=self.clock))
            seat = Seat(participant, new_page_secret(), session, self.clock(), budget, hold)
            self._pages[seat.page] = seat
            self._participants[participant] = seat
            return seat

    def page(self, page: object) -> Seat | None:
        """The seat of a page id the page sent, if it still holds one; hearing from it keeps it."""
        if not is_page_secret(page):
            return None
        with self._lock:
            seat = self._pages.get(page)
            if seat is not None:
                seat.seen = self.clock()
            return seat

    def keep_alive(self, page: object) -> bool:
        """The page's heartbeat: whether it still holds a seat (hearing from it keeps it)."""
        return self.page(page) is not None

    @contextlib.contextmanager
    def playing(self, page: object) -> Iterator[Seat | None]:
        """The seat of `page` under its lock (None: it holds none); a session that left frees its seat after."""
        seat = self.page(page)
        if seat is None:
            yield None
            return
        with seat.lock:
            yield seat
        if seat.session.left:  # q, a recording that cannot be written, a lock refused
            self.release(seat)

    def leave(self, page: object, why: str) -> None:
        """The page closed: its seat, if it holds one, is released."""
        seat = self.page(page)
        if seat is not None:
            self.release(seat, why)

    def release(self, seat: Seat, why: str = "left") -> None:
        """The page left: its session records what was running and closes its file."""
        with self._lock:
            if self._pages.get(seat.page) is seat:
                self._release(seat, why)

    def release_silent(self) -> None:
        """Release every page not heard from for `silent_s`."""
        with self._lock:
            for seat in [s for s in self._pages.values() if self.clock() - s.seen >= self.silent_s]:
                self._release(seat, "left (the page went silent)")
            # Full buckets are what a new one would be: forgetting them keeps invented ids from piling up.
            for budgets in (self._budgets, self._addresses):
                for name in [name for name, budget in budgets.items() if budget.full()]:
                    if name not in self._participants:
                        del budgets[name]

    def release_all(self, why: str) -> None:
        with self._lock:
            for seat in list(self._pages.values()):
                self._release(seat, why)

    def __len__(self) -> int:
        return len(self._pages)

    def _release(self, seat: Seat, why: str) -> None:
        del self._pages[seat.page]
        del self._participants[seat.participant]
        with seat.lock:
            try:
                seat.session.leave(why)
            finally:
                seat.held.close()
