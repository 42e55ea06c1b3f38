"""When a key event reached the app: how the play and calibration screens time keys.

Textual stamps an event with `time.monotonic()` as it makes it (`Message.time`), and its driver
makes a key event in its input thread as it reads the key: the stamp is the key's arrival
however long the event then waits to be handled (a slow redraw, a busy machine). A screen timed
by `time.monotonic` (where the game runs) times each key by that stamp; a screen on another
clock (a test's fake clock) times a key as it is handled, unless the test stamps its events on
that clock and says so (`event_times=True`).
"""

from __future__ import annotations

import time

from textual import events

from irl_core.play.hold import Clock


class KeyArrival:
    """Call with a key event for when it reached the app, on `clock` (seconds).

    `event_times` says whether events' own times are on `clock` (None: when `clock` is
    `time.monotonic`, Textual's clock).
    """

    def __init__(self, clock: Clock, *, event_times: bool | None = None) -> None:
        self.clock = clock
        self.event_times = clock is time.monotonic if event_times is None else event_times

    def __call__(self, event: events.Event) -> float:
        return event.time if self.event_times else self.clock()
