"""A screen's timer tick that runs behind the keys already read: how play and calibration judge a silence.

Both screens end something at a silence since the last key (play a hold, calibration the
attempt). After a stall of the event loop (a slow redraw, a garbage collection) the timer's
wake-up and the keys Textual's input thread read meanwhile are all in the loop's line, the
timer's possibly first, and the keys that reached the app's queue still wait there to be handled:
the silence since the last key handled is then no silence. `TickBehindInput` lets the keys on
their way reach a queue before the tick, and tells the tick whether any wait there.
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from textual.app import App

# Event-loop turns a key takes from Textual's input thread into the app's queue (Textual 8.2.8:
# the thread schedules a coroutine, the coroutine queues the key).
TURNS_TO_QUEUE = 2


class _Ticking(Protocol):
    """What the mixin needs of its screen."""

    @property
    def app(self) -> App[object]: ...

    @property
    def message_queue_size(self) -> int: ...

    def clock(self) -> float: ...

    def tick(self, *, input_until: float) -> None: ...


class TickBehindInput:
    """Mixin for a `Screen` whose timer runs `_tick_behind_input`.

    The screen has `clock` (its clock, seconds) and `tick(*, input_until)`, which judges a
    silence up to `input_until` and only when `input_waiting()` is false (a message that is no
    key only delays the end by a tick). Not covered: a stop of the whole process (the input
    thread too), whose keys are read, and stamped, only when it resumes.
    """

    async def _tick_behind_input(self: _Ticking) -> None:
        """The timer's tick, run once every key that reached the app before it is in a queue.

        Letting the loop turn `TURNS_TO_QUEUE` times puts the keys on their way in the app's
        queue, where `tick` sees them; the silence is judged up to when this tick began, as a
        key that came later is not yet known to be queued.
        """
        began = self.clock()
        for _ in range(TURNS_TO_QUEUE):
            await asyncio.sleep(0)
        self.tick(input_until=began)

    def input_waiting(self: _Ticking) -> bool:
        """Whether the app's or this screen's queue holds a message (a key, maybe) not yet handled."""
        return self.app.message_queue_size > 0 or self.message_queue_size > 0
