"""A calibration whose keys are handled late still measures the autorepeat they showed (Pilot).

While the app is stalled (a slow frame, a busy machine) the terminal's press and autorepeats
queue up and are handled together when it resumes. Timed by when they were handled, a stall
over the first repeat stretches the measured delay to its end, and keys handled in bunches
make most repeat gaps 0, so the median period is clamped to 10 ms: every later hold is then
read with the wrong rhythm. The screen times each key by its arrival (`careful_tui.keys.arrival`).

A stall once the repeats run is a silence to a timer that wakes before the keys queued behind it
are handled: the attempt would end ("Measured.") while the key is still held, from the repeats
before the stall. As play does, the screen judges a silence only once the keys that came are
handled (`careful_tui.screens.behind_input`).
"""

from __future__ import annotations

import asyncio
import math
import statistics
import threading
import time
from dataclasses import dataclass
from itertools import groupby
from pathlib import Path

import pytest
from play_fixtures import FakeClock, corner_world
from test_play_redraw import visible
from textual import events
from textual.pilot import Pilot

from careful_tui.app import CarefulApp, new_play_screen
from careful_tui.screens.calibration import CalibrationScreen
from irl_core.play.calibration import SILENCE_S

DELAY = 0.5
PERIOD = 0.033
HELD = 2.0
# The arrivals are given exactly, so the measurement is exact but for float rounding.
TOLERANCE_MS = 0.01


def calibrating_app(tmp_path: Path, clock, **options) -> CarefulApp:
    """Play opening on its calibration screen (`--calibrate`), in hold mode on `clock`."""
    return CarefulApp(new_play_screen(corner_world(), out=tmp_path / "rec", player="tester", seed=1,
                                      input_mode="hold", clock=clock, calibrate=True, **options))


def stamped_key(key: str, at: float) -> events.Key:
    """A legacy terminal's key event (press or autorepeat alike) that reached the app at `at`."""
    event = events.Key(key, None)
    event.time = at
    return event


def autorepeat(start: float) -> list[float]:
    """A press at `start`, autorepeats from `DELAY` every `PERIOD` to `HELD` s after it."""
    count = math.floor((HELD - DELAY) / PERIOD) + 1
    return [start, *(start + DELAY + k * PERIOD for k in range(count))]


def stalled_over_first_repeat(start: float, arrival: float) -> float:
    """When a loop stalled from 0.3 s to 0.9 s after the press handles a key that came at `arrival`."""
    stall_from, stall_ends = start + 0.3, start + 0.9
    return stall_ends if stall_from <= arrival < stall_ends else arrival


def busy_in_bunches(start: float, arrival: float) -> float:
    """When a loop that gets to its keys only every 100 ms (a slow frame each time) handles one."""
    return start + math.ceil(round((arrival - start) / 0.1, 9)) * 0.1


@pytest.mark.parametrize("handled_at", [stalled_over_first_repeat, busy_in_bunches])
def test_keys_handled_late_measure_the_delay_and_period_they_came_with(tmp_path: Path, handled_at) -> None:
    clock = FakeClock()
    start = clock.now
    arrivals = autorepeat(start)
    handled = [handled_at(start, t) for t in arrivals]
    assert sum(h > t + 0.05 for t, h in zip(arrivals, handled)) >= 10, "keys handled over 50 ms late"
    app = calibrating_app(tmp_path, clock, event_times=True)
    seen: dict[str, object] = {}

    async def body(pilot: Pilot) -> None:
        screen = app.screen
        assert isinstance(screen, CalibrationScreen)
        for when, came in groupby(zip(handled, arrivals), key=lambda pair: pair[0]):
            clock.now = when
            screen.tick()  # the screen's timer may run before the keys that wait for it
            for _, arrival in came:
                app.post_message(stamped_key("up", arrival))
            await pilot.pause()
            assert screen.calibrating.result is None and screen.calibrating.problem is None, f"the attempt ended at {when - start:.2f} s"
        measured = seen["measured"] = screen.calibrating.calibration.result()
        assert measured.initial_delay_ms == pytest.approx(DELAY * 1000, abs=TOLERANCE_MS)
        assert measured.repeat_period_ms == pytest.approx(PERIOD * 1000, abs=TOLERANCE_MS)
        # The silence after the last key counts from its arrival, on the screen's clock.
        clock.now = arrivals[-1] + SILENCE_S - 0.01
        screen.tick()
        assert screen.calibrating.result is None, "the attempt ended before a silence"
        clock.now = arrivals[-1] + SILENCE_S + 1e-6
        screen.tick()
        await pilot.pause()
        assert screen.calibrating.result is not None, "no end SILENCE_S after the last key's arrival"
        seen["shown"] = " ".join(visible(screen.query_one("#calibration-text")).split())
        await pilot.press("enter")
        await pilot.pause()
        seen["profile"] = app.screen.profile

    async def main() -> None:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(main())
    assert seen["profile"] == seen["measured"] and seen["profile"].calibrated, "play goes on with the profile measured"
    assert "Autorepeat starts after 500 ms and repeats every 33 ms." in seen["shown"]


@dataclass
class RealHold:
    """What `hold_through_a_real_stall` saw: when each key was sent, the screen after the attempt,
    and how far into the hold (s) the attempt ended while the key was still held, if it did."""

    sent: list[float]
    screen: CalibrationScreen
    ended_while_held: float | None

    @property
    def gaps_ms(self) -> list[float]:
        return [(b - a) * 1000 for a, b in zip(self.sent, self.sent[1:])]


def hold_through_a_real_stall(tmp_path: Path, *, stall_at: float, held_s: float, period: float = 0.04) -> RealHold:
    """Real time: a thread types like a terminal's input thread (a press, repeats from `DELAY`
    every `period` to `held_s`) while the loop blocks for 600 ms from `stall_at` s after the press."""
    app = calibrating_app(tmp_path, time.monotonic)
    sent: list[float] = []

    def keyboard() -> None:
        sent.append(time.monotonic())
        app._driver.process_message(events.Key("up", None))
        time.sleep(DELAY)
        while time.monotonic() - sent[0] < held_s:
            sent.append(time.monotonic())
            app._driver.process_message(events.Key("up", None))
            time.sleep(period)

    async def main() -> RealHold:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            screen = app.screen
            assert isinstance(screen, CalibrationScreen)

            def ended() -> bool:
                return screen.calibrating.result is not None or screen.calibrating.problem is not None

            typing = threading.Thread(target=keyboard)
            typing.start()
            await pilot.pause(stall_at)
            time.sleep(0.6)  # the loop blocks: nothing is handled, the keys queue up
            ended_while_held = None
            while typing.is_alive():
                await pilot.pause(0.05)
                if ended() and ended_while_held is None:
                    ended_while_held = time.monotonic() - sent[0]
            for _ in range(100):  # the attempt ends SILENCE_S after the last repeat
                if ended():
                    break
                await pilot.pause(0.02)
            return RealHold(sent, screen, ended_while_held)

    return asyncio.run(main())


def test_a_real_stall_of_the_event_loop_over_the_first_repeat_leaves_the_delay_measured(tmp_path: Path) -> None:
    hold = hold_through_a_real_stall(tmp_path, stall_at=0.3, held_s=1.5)
    screen, gaps_ms = hold.screen, hold.gaps_ms
    assert hold.ended_while_held is None, f"ended {hold.ended_while_held:.2f} s into the hold"
    assert screen.calibrating.problem is None and screen.calibrating.result is not None, gaps_ms
    # Stamped as it is made, a key event's time is its sending's to within the thread's switch
    # (5 ms, more on a loaded machine); handled after the stall, the delay would be 900 ms.
    assert screen.calibrating.result.initial_delay_ms == pytest.approx(gaps_ms[0], abs=25.0), gaps_ms
    assert screen.calibrating.result.repeat_period_ms == pytest.approx(statistics.median(gaps_ms[1:]), abs=5.0), gaps_ms


def test_autorepeats_queued_behind_a_stall_once_the_repeats_run_do_not_end_the_attempt(tmp_path: Path) -> None:
    clock = FakeClock()
    start = clock.now
    arrivals = autorepeat(start)
    stall_from, stall_ends = start + 0.8, start + 1.4
    app = calibrating_app(tmp_path, clock, event_times=True)

    async def body(pilot: Pilot) -> None:
        screen = app.screen
        backlog = [t for t in arrivals if stall_from <= t < stall_ends]
        assert len(backlog) == 18 and stall_ends - max(t for t in arrivals if t < stall_from) > SILENCE_S
        assert isinstance(screen, CalibrationScreen)
        for t in arrivals:
            if t in backlog:
                continue
            if t >= stall_ends and backlog:
                # The stall ends: the keys read meanwhile are on their way from the driver to
                # the app's queue, and the timer's tick is first.
                clock.now = stall_ends
                for queued in backlog:
                    app._driver.process_message(stamped_key("up", queued))
                await screen._tick_behind_input()
                ended = screen.calibrating.result is not None or screen.calibrating.problem is not None
                await pilot.pause()  # (the keys in transit are handled before any assertion can stop the app)
                assert not ended, "the timer ended the attempt while its repeats were on their way"
                backlog = []
            clock.now = t
            app.post_message(stamped_key("up", t))
            await pilot.pause()
            await screen._tick_behind_input()
            assert screen.calibrating.result is None and screen.calibrating.problem is None, f"the attempt ended at {t - start:.2f} s"
        assert screen.calibrating.calibration.repeats == len(arrivals) - 1
        clock.now = arrivals[-1] + SILENCE_S + 1e-6
        await screen._tick_behind_input()
        assert screen.calibrating.result is not None, "no end SILENCE_S after the last key's arrival"
        assert screen.calibrating.result.initial_delay_ms == pytest.approx(DELAY * 1000, abs=TOLERANCE_MS)
        assert screen.calibrating.result.repeat_period_ms == pytest.approx(PERIOD * 1000, abs=TOLERANCE_MS)

    async def main() -> None:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(main())


def test_a_real_stall_of_the_event_loop_once_the_repeats_run_leaves_the_attempt_going(tmp_path: Path) -> None:
    """The loop blocks from 0.8 s after the press (the repeats began at 0.5 s) to 1.4 s; the key is let go at 2 s."""
    hold = hold_through_a_real_stall(tmp_path, stall_at=0.8, held_s=2.0)
    screen, gaps_ms = hold.screen, hold.gaps_ms
    assert hold.ended_while_held is None, \
        f"ended {hold.ended_while_held:.2f} s into the hold, repeats sent {[round(gap) for gap in gaps_ms]} ms apart"
    assert screen.calibrating.problem is None and screen.calibrating.result is not None, gaps_ms
    used, sent = screen.calibrating.calibration.repeats, len(hold.sent) - 1
    assert used == sent, f"{used} of {sent} repeats used"
    assert screen.calibrating.result.repeat_period_ms == pytest.approx(statistics.median(gaps_ms[1:]), abs=5.0), gaps_ms
