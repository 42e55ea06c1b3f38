"""One page per participant, and a bound on how fast a page may send keys.

A participant plays on one page at a time: a second tab or device that opens their link while the
first is open is refused (never interleaved into the same file). A page holds its seat while it
is heard from (every key, and a heartbeat every few seconds); one that closes says so
(`navigator.sendBeacon`), and one silent for `SILENT_S` has left: its seat goes to the next page
that asks. A seat also holds the participant's lock (`irl_core.studies.participant_lock`, the one
`careful study run` takes), so a terminal session and a page never play one participant at once,
in this process or another.

`KeyBudget` is a token bucket per participant: `KEY_BURST` key events at once, then `KEY_RATE`
a second (four moves a second sustained is more than a person makes, holding a key for each).
"""

from __future__ import annotations

import contextlib
import secrets
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field

from careful_tui.web.session_adapter import WebSession

# A hidden tab's timers may run once a minute (Chrome's intensive throttling): its heartbeat still arrives.
SILENT_S = 90.0
KEY_BURST = 24
KEY_RATE = 12.0


class KeyBudget:
    """A token bucket: `spend` is True while the page keeps within `burst` events and `rate` a second."""

    def __init__(self, *, burst: int = KEY_BURST, rate: float = KEY_RATE, clock: Callable[[], float] = time.monotonic):
        self.burst, self.rate, self.clock = burst, rate, clock
        self.tokens = float(burst)
        self.at = clock()

    def spend(self) -> bool:
        now = self.clock()
        self.tokens = min(self.burst, self.tokens + (now - self.at) * self.rate)
        self.at = now
        if self.tokens < 1:
            return False
        self.tokens -= 1
        return True


@dataclass
class Seat:
    """A participant's page: its unguessable id, its session, when it was last heard from."""

    participant: str
    page: str
    session: WebSession
    seen: float
    budget: KeyBudget
    held: contextlib.ExitStack
    lock: threading.Lock = field(default_factory=threading.Lock)


class Seats:
    """The pages playing now, one per participant."""

    def __init__(self, *, clock: Callable[[], float] = time.monotonic, silent_s: float = SILENT_S) -> None:
        self.clock = clock
        self.silent_s = silent_s
        self._lock = threading.Lock()
        self._pages: dict[str, Seat] = {}
        self._participants: dict[str, Seat] = {}

    def claim(self, participant: str, make_session: Callable[[], WebSession], *,
              hold: Callable[[], AbstractContextManager[object]] = contextlib.nullcontext) -> Seat | None:
        """A seat for a new page of `participant`, or None while another page of theirs plays.

        `hold` makes the participant's lock, held as long as the seat.

        Raises:
            irl_core.studies.participant_lock.ParticipantBusy: another process plays the participant.
        """
        with self._lock:
            held = self._participants.get(participant)
            if held is not None:
                if self.clock() - held.seen < self.silent_s:
                    return None
                self._release(held, "left (the page went silent)")
            with contextlib.ExitStack() as stack:
                stack.enter_context(hold())
                session = make_session()
                kept = stack.pop_all()
            seat = Seat(participant, secrets.token_urlsafe(18), session, self.clock(), KeyBudget(clock=self.clock), kept)
            self._pages[seat.page] = seat
            self._participants[participant] = seat
            return seat

    def page(self, page: object) -> Seat | None:
        """The seat of a page id the page sent, if it still holds one; hearing from it keeps it."""
        if not isinstance(page, str):
            return None
        with self._lock:
            seat = self._pages.get(page)
            if seat is not None:
                seat.seen = self.clock()
            return seat

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
