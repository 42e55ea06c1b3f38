"""The hold detector timed by when key events happened, not when they were handled, and its
cancel (a dropped move whose key is still held), under a fake clock.

A stalled app handles the key events that came during the stall all at once, late. The
detector is handed each event's own time (`at`), so the stall changes nothing it measures.
"""

from __future__ import annotations

import pytest
from play_fixtures import FakeClock

from irl_core.play.hold import Hold, HoldDetector, HoldProfile
from irl_core.play.modes import TapCounter

PROFILE = HoldProfile()
PERIOD = 0.033


def autorepeat(until: float, *, delay: float = 0.5, period: float = PERIOD) -> list[float]:
    """Times of a press at 0 and its autorepeats (from `delay`, every `period`) up to `until`."""
    count = int((until - delay) / period + 1e-9) + 1
    return [0.0, *(round(delay + k * period, 6) for k in range(count))]


def handled_times(times: list[float], *, stall_from: float, stall_s: float) -> list[float]:
    """When an app handles events that came at `times` if it stalls for `stall_s` from `stall_from`:
    at once before and after the stall; the events that came during it, all when it ends."""
    stall_ends = stall_from + stall_s
    return [stall_ends if stall_from <= t < stall_ends else t for t in times]


def feed(detector: HoldDetector | TapCounter, clock: FakeClock, key: str, times: list[float],
         handled: list[float]) -> list[Hold]:
    """Feed events that happened at `times`, each handled at `handled`, then wait the move out.

    Like the play screen, poll only when no event waits: before an event handled on time, never
    while a stall's backlog is being handled.
    """
    done: list[Hold] = []
    for t, handled_at in zip(times, handled, strict=True):
        clock.now = handled_at
        if handled_at == t:
            done += detector.poll()
        done += detector.press(key, at=t)
    deadline = detector.deadline()
    assert deadline is not None
    clock.now = deadline
    done += detector.poll()
    return done


def test_a_stall_of_600_ms_mid_hold_leaves_one_hold_of_the_right_length_and_level() -> None:
    clock = FakeClock(0.0)
    times = autorepeat(1.6)
    handled = handled_times(times, stall_from=0.81, stall_s=0.6)
    assert sum(h > t for t, h in zip(times, handled)) == 18, "the stall delays 18 repeats, 33 ms apart"
    (hold,) = feed(HoldDetector(PROFILE, clock=clock), clock, "right", times, handled)
    expected_ms = times[-1] * 1000 + PERIOD * 1000 / 2
    assert hold.hold_ms == pytest.approx(expected_ms)
    assert hold.level == PROFILE.level_for(expected_ms) == 9
    assert hold.repeats == len(times) - 1 and not hold.exact


def test_a_release_after_a_stall_measures_the_hold_by_when_it_came() -> None:
    clock = FakeClock(0.0)
    detector = HoldDetector(PROFILE, clock=clock)
    detector.press("up", repeat=False, at=0.0)
    clock.now = 1.5  # the release came at 0.9 but waited behind a stall
    (hold,) = detector.release("up", at=0.9)
    assert hold.exact and hold.hold_ms == pytest.approx(900.0) and hold.level == PROFILE.level_for(900.0)


def test_taps_handled_late_in_a_bunch_count_as_the_taps_they_were() -> None:
    clock = FakeClock(0.0)
    taps = [0.0, 0.15, 0.3, 0.45]
    (move,) = feed(TapCounter(PROFILE, clock=clock), clock, "left", taps,
                   handled_times(taps, stall_from=0.1, stall_s=0.6))
    assert move.level == 4 and move.hold_ms == pytest.approx(450.0)


# --- cancel: the move is dropped, its key may still be held ---------------------------------


def cancelled_mid_hold(clock: FakeClock) -> HoldDetector:
    """A hold of right, its repeats up to 0.8 s, cancelled then."""
    detector = HoldDetector(PROFILE, clock=clock)
    for t in autorepeat(0.8):
        clock.now = t
        detector.press("right")
    detector.cancel()
    assert detector.current() is None and detector.deadline() is None
    return detector


def test_after_a_cancel_the_held_keys_autorepeats_start_no_hold() -> None:
    clock = FakeClock(0.0)
    detector = cancelled_mid_hold(clock)
    t = 0.8
    while t < 3.0:  # still held for over 2 s
        t += PERIOD
        clock.now = t
        assert detector.press("right") == [] and detector.current() is None
        assert detector.poll() == []
    clock.now = t + 0.5  # let go: silence, then a new press is a move again
    assert detector.poll() == []
    detector.press("right")
    assert detector.current() is not None and detector.current().key == "right"


def test_after_a_cancel_another_key_or_an_explicit_press_or_release_starts_afresh() -> None:
    clock = FakeClock(0.0)
    detector = cancelled_mid_hold(clock)
    clock.now = 0.85
    detector.press("down")
    assert detector.current().key == "down"

    detector = cancelled_mid_hold(clock)
    clock.now = 0.85
    detector.press("right", repeat=True)  # kitty: the cancelled key's repeat
    assert detector.current() is None
    detector.press("right", repeat=False)  # kitty: pressed again
    assert detector.current().key == "right"

    detector = cancelled_mid_hold(clock)
    detector.release("right")
    clock.now = 0.85
    detector.press("right")  # after its release, the same key within the timeout is a new press
    assert detector.current().key == "right"


def test_a_cancel_before_any_repeat_ignores_the_first_repeat_but_not_a_second_press() -> None:
    clock = FakeClock(0.0)
    detector = HoldDetector(PROFILE, clock=clock)
    detector.press("right", at=0.0)
    detector.cancel()
    detector.press("right", at=0.5)  # the key still down: its first autorepeat
    assert detector.current() is None

    detector = HoldDetector(PROFILE, clock=clock)
    detector.press("right", at=0.0)
    detector.cancel()
    detector.press("right", at=0.1)  # sooner than any autorepeat: let go and pressed again
    assert detector.current() is not None
