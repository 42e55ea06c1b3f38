"""A play screen that stalls mid-hold still makes one move of the length held (Pilot).

While the app is stalled (a slow redraw, a garbage collection) the terminal's autorepeats queue
up; when it resumes, the screen's timer may run before they are handled. Timed by when they were
handled, or polled while they wait, they split one held key into two moves.
"""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path

import pytest
from play_fixtures import FakeClock, corner_world
from textual import events
from textual.pilot import Pilot

from careful_tui.app import CarefulApp, new_play_screen
from careful_tui.screens.play import PlayScreen
from irl_core.play.hold import HoldProfile
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.lines import Step

PROFILE = HoldProfile(levels=14)
PERIOD = 0.033


def play_app(tmp_path: Path, clock, **options) -> CarefulApp:
    return CarefulApp(new_play_screen(corner_world(), out=tmp_path / "rec", player="tester", seed=1,
                                      input_mode="hold", clock=clock, **options))


def key_event(key: str, at: float) -> events.Key:
    """A legacy terminal's key event (press or autorepeat, not told apart) that reached the app at `at`."""
    event = events.Key(key, None)
    event.time = at
    return event


def steps(app: CarefulApp) -> list[Step]:
    screen = app.first_screen
    assert isinstance(screen, PlayScreen)
    return [step for path in screen.recorder.paths for step in read_recording(path).steps]


def test_autorepeats_queued_behind_a_600_ms_stall_extend_the_hold(tmp_path: Path) -> None:
    clock = FakeClock()
    started = clock.now
    app = play_app(tmp_path, clock, event_times=True)
    times = [started, *(started + 0.5 + k * PERIOD for k in range(34))]  # held 1.589 s
    stall_from, stall_ends = started + 0.81, started + 1.41

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        backlog = [t for t in times if stall_from <= t < stall_ends]
        assert len(backlog) == 18
        for t in times:
            if t in backlog:
                continue
            if t >= stall_ends and backlog:
                # The stall ends: the keys read meanwhile are on their way from the driver to
                # the app's queue, and the timer's tick (what the screen's timer runs) is first.
                clock.now = stall_ends
                for queued in backlog:
                    app._driver.process_message(key_event("right", queued))
                await screen._tick_behind_input()
                moves_made = screen.game.t
                await pilot.pause()  # (the keys in transit are handled before any assertion can stop the app)
                assert moves_made == 0, "the timer ended the hold while its repeats were on their way"
                backlog = []
            clock.now = t
            app.post_message(key_event("right", t))
            await pilot.pause()
            screen.tick()
        clock.advance(1.0)
        screen.tick()
        await pilot.pause()

    async def main() -> None:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            await body(pilot)

    asyncio.run(main())
    expected_ms = (times[-1] - started) * 1000 + PERIOD * 1000 / 2
    (step,) = steps(app)
    assert step.direction == "right" and not step.hold_exact
    assert step.hold_ms == pytest.approx(expected_ms, abs=0.01)
    assert step.carefulness == PROFILE.level_for(expected_ms) == 9


def test_a_real_stall_of_the_event_loop_mid_hold_makes_one_move(tmp_path: Path) -> None:
    """Real time: a thread types like a terminal's input thread while the loop blocks for 600 ms."""
    app = play_app(tmp_path, time.monotonic)
    period, held_s = 0.08, 1.5  # the repeat timeout is then 240 ms: no thread jitter ends the hold
    sent: list[float] = []

    def keyboard() -> None:
        sent.append(time.monotonic())
        app._driver.process_message(events.Key("right", None))
        time.sleep(0.5)
        while time.monotonic() - sent[0] < held_s:
            sent.append(time.monotonic())
            app._driver.process_message(events.Key("right", None))
            time.sleep(period)

    async def main() -> None:
        async with app.run_test(size=(100, 35)) as pilot:
            await pilot.pause()
            typing = threading.Thread(target=keyboard)
            typing.start()
            await pilot.pause(0.7)
            time.sleep(0.6)  # the loop blocks: nothing is handled, the keys queue up
            while typing.is_alive():
                await pilot.pause(0.05)
            for _ in range(100):  # the hold ends 240 ms after the last repeat
                await pilot.pause(0.02)
                if app.first_screen.input.current() is None:
                    break

    asyncio.run(main())
    gaps_ms = [round((b - a) * 1000) for a, b in zip(sent, sent[1:])]
    made = [(step.carefulness, round(step.hold_ms)) for step in steps(app)]
    assert len(made) == 1, f"moves {made} from keys sent with gaps {gaps_ms} ms"
    assert made[0][1] == pytest.approx((sent[-1] - sent[0]) * 1000, abs=period * 1000), gaps_ms
