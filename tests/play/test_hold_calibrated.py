"""Play's feel for participants, in the hold detector and the calibration (plain classes, fake clock):
how long a tap waits before it is a move, with and without calibration, and a second tap of the
same arrow during that wait."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from play_fixtures import FakeClock
from test_hold import repeat_times, run_hold

from irl_core.play.calibration import Calibration
from irl_core.play.hold import HoldDetector, HoldProfile
from irl_core.play.modes import TapCounter


def calibrated(delay_s: float, period_s: float, *, gaps_s: list[float] | None = None) -> HoldProfile:
    """The profile a 2 s calibration hold gives: repeats after `delay_s`, then every `period_s`
    (or after each of `gaps_s`)."""
    calibration = Calibration(HoldProfile())
    times = [0.0, delay_s]
    for gap in gaps_s or [period_s] * int(1.6 / period_s):
        times.append(times[-1] + gap)
    for t in times:
        calibration.feed("up", t)
    return calibration.result()


# --- the wait before a tap is a move ------------------------------------------------------


def test_without_calibration_a_tap_waits_700_ms() -> None:
    profile = HoldProfile()
    assert profile.first_repeat_timeout_ms == 700.0
    assert profile.to_header()["tap_wait_ms"] == 700.0


@pytest.mark.parametrize(("delay_s", "period_s", "wait_ms", "second_press_ms"), [
    (0.5, 0.033, 600.0, 400.0),  # margin: the 100 ms floor (3 periods are 99 ms)
    (0.25, 0.033, 350.0, 150.0),  # a fast keyboard: half the uncalibrated wait
    (0.66, 0.04, 780.0, 540.0),  # X11's default: 3 periods (120 ms) are the margin; longer than 700
])
def test_calibration_sets_the_wait_from_the_measured_delay(delay_s: float, period_s: float, wait_ms: float,
                                                            second_press_ms: float) -> None:
    profile = calibrated(delay_s, period_s)
    assert profile.first_repeat_timeout_ms == pytest.approx(wait_ms)
    assert profile.earliest_repeat_ms == pytest.approx(second_press_ms)
    header = profile.to_header()
    assert header["tap_wait_ms"] == pytest.approx(wait_ms)
    assert header["second_press_within_ms"] == pytest.approx(second_press_ms)


def test_a_jittery_keyboard_gets_a_wider_margin() -> None:
    # Gaps of 10 and 50 ms: median 30, every gap 20 ms off it, so the robust spread is
    # 1.4826 x 20 = 29.65 ms and the margin 6 x 29.65 = 177.9 ms (more than 100 ms or 3 x 30 ms).
    profile = calibrated(0.5, 0.03, gaps_s=[0.01, 0.05] * 25)
    assert profile.repeat_period_ms == pytest.approx(30.0)
    assert profile.first_repeat_margin_ms == pytest.approx(6 * 1.4826 * 20.0)
    assert profile.first_repeat_timeout_ms == pytest.approx(500.0 + 177.912)


def test_a_calibrated_tap_is_a_move_after_the_shorter_wait() -> None:
    clock = FakeClock(0.0)
    detector = HoldDetector(calibrated(0.3, 0.03), clock=clock)
    detector.press("up")
    clock.now = 0.399
    assert detector.poll() == []
    clock.now = 0.4
    [tap] = detector.poll()
    assert (tap.key, tap.level, tap.hold_ms) == ("up", 1, 0.0)


@given(delay_ms=st.floats(150.0, 1000.0), period_ms=st.floats(10.0, 200.0), late=st.floats(0.0, 1.0),
       length_ms=st.floats(0.0, 3000.0))
def test_a_calibrated_hold_is_one_move_when_its_first_repeat_is_late_within_the_margin(
        delay_ms: float, period_ms: float, late: float, length_ms: float) -> None:
    """The same keyboard as calibrated, its first repeat delivered up to a margin off: never split."""
    profile = calibrated(delay_ms / 1000, period_ms / 1000)
    margin_s = profile.first_repeat_margin_ms / 1000
    times = repeat_times(length_ms / 1000, delay_s=delay_ms / 1000, period_s=period_ms / 1000)
    if len(times) > 1:
        # Early or late by up to the margin, but not before the press.
        shift = max((2 * late - 1) * margin_s * 0.999, 0.001 - delay_ms / 1000)
        times = [0.0] + [t + shift for t in times[1:]]
    clock = FakeClock(0.0)
    [hold] = run_hold(HoldDetector(profile, clock=clock), clock, "down", times)
    assert hold.repeats == len(times) - 1


# --- a second tap during the wait ---------------------------------------------------------


def presses(detector: HoldDetector, clock: FakeClock, key: str, times: list[float]) -> list:
    done = []
    for t in times:
        clock.now = t
        done += detector.poll() + detector.press(key)
    clock.now = detector.deadline() or clock.now
    return done + detector.poll()


def test_uncalibrated_two_taps_within_150_ms_are_two_moves() -> None:
    clock = FakeClock(0.0)
    [first, second] = presses(HoldDetector(HoldProfile(), clock=clock), clock, "left", [0.0, 0.12])
    assert (first.level, first.started, second.level, second.started) == (1, 0.0, 1, 0.12)


def test_uncalibrated_a_second_tap_after_150_ms_may_be_an_autorepeat() -> None:
    """Without calibration the delay is unknown: 300 ms could be a fast keyboard's first repeat."""
    clock = FakeClock(0.0)
    [hold] = presses(HoldDetector(HoldProfile(), clock=clock), clock, "left", [0.0, 0.3])
    assert hold.repeats == 1


def test_calibrated_two_taps_before_the_delay_are_two_moves_and_a_hold_is_one() -> None:
    clock = FakeClock(0.0)
    profile = calibrated(0.5, 0.033)  # a second press before 400 ms
    detector = HoldDetector(profile, clock=clock)
    moves = presses(detector, clock, "down", [0.0, 0.39])
    assert [(m.level, m.repeats, m.started) for m in moves] == [(1, 0, 0.0), (1, 0, 0.39)]
    # Three quick taps: three moves.
    moves = presses(detector, clock, "down", [10.0, 10.2, 10.35])
    assert [m.started for m in moves] == [10.0, 10.2, 10.35]
    # A hold of the same arrow: one move whose level comes from its length.
    [hold] = presses(detector, clock, "down", [20 + t for t in repeat_times(1.0, delay_s=0.5, period_s=0.033)])
    assert hold.level == profile.level_for(hold.hold_ms) >= 4


def test_once_repeats_run_the_same_arrow_extends_the_hold() -> None:
    clock = FakeClock(0.0)
    detector = HoldDetector(calibrated(0.5, 0.033), clock=clock)
    # A press, its first repeat, then an event 2.5 periods later (off the rhythm, within the timeout).
    [hold] = presses(detector, clock, "up", [0.0, 0.5, 0.58])
    assert hold.repeats == 2


def test_tap_mode_counts_quick_taps_as_levels() -> None:
    """README "Playing": in tap mode k quick taps of one arrow are one move at level k, however quick."""
    clock = FakeClock(0.0)
    counter = TapCounter(calibrated(0.5, 0.033), clock=clock)
    for t in (0.0, 0.08, 0.16):
        clock.now = t
        assert counter.press("right") == []
    clock.now = 0.16 + counter.tap_window_ms / 1000
    [move] = counter.poll()
    assert (move.key, move.level, move.repeats) == ("right", 3, 2)
