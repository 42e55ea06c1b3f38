"""The hold detector, its fallback modes and the calibration, driven by a fake clock."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from play_fixtures import FakeClock

from irl_core.play.calibration import Calibration
from irl_core.play.hold import ActiveHold, Hold, HoldDetector, HoldProfile
from irl_core.play.input_modes import input_mode
from irl_core.play.modes import DigitsInput, TapCounter


def repeat_times(length_s: float, *, delay_s: float, period_s: float) -> list[float]:
    """Event times of one hold: the press at 0, then autorepeats while the key is down."""
    times = [0.0]
    k = 0
    while delay_s + k * period_s <= length_s:
        times.append(delay_s + k * period_s)
        k += 1
    return times


def run_hold(
    detector: HoldDetector, clock: FakeClock, key: str, times: list[float]
) -> list[Hold]:
    """Feed a hold's events, polling before each one as a timer would, then wait it out."""
    done: list[Hold] = []
    for t in times:
        clock.now = t
        assert detector.poll() == [], f"hold ended early, at {t:.3f} s"
        done += detector.press(key)
    deadline = detector.deadline()
    assert deadline is not None
    clock.now = deadline
    done += detector.poll()
    return done


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock(0.0)


@pytest.fixture
def detector(clock: FakeClock) -> HoldDetector:
    return HoldDetector(HoldProfile(), clock=clock)


# --- the level scale ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("hold_ms", "level"),
    [
        (0.0, 1),
        (499.9, 1),
        (500.0, 2),
        (649.9, 2),
        (650.0, 3),
        (1500.0, 8),
        (2299.9, 13),
        (2300.0, 14),
        (60_000.0, 14),
    ],
)
def test_level_table_with_default_profile(hold_ms: float, level: int) -> None:
    assert HoldProfile().level_for(hold_ms) == level


def test_level_is_capped_at_the_worlds_levels() -> None:
    assert HoldProfile(levels=5).level_for(10_000.0) == 5
    assert HoldProfile(levels=1).level_for(10_000.0) == 1


@given(
    delay=st.floats(150.0, 1000.0),
    per_level=st.floats(20.0, 400.0),
    levels=st.integers(1, 20),
    data=st.data(),
)
def test_each_level_starts_where_the_profiles_table_says(
    delay: float, per_level: float, levels: int, data: st.DataObject
) -> None:
    profile = HoldProfile(initial_delay_ms=delay, ms_per_level=per_level, levels=levels)
    level = data.draw(st.integers(1, levels))
    # The table: level 1 below T, then level k from T + (k - 2) m.
    shortest = 0.0 if level == 1 else profile.tap_ms + (level - 2) * profile.ms_per_level
    assert profile.level_for(shortest) == level
    if level > 1:
        assert profile.level_for(shortest - 0.01) == level - 1


def test_profile_rejects_nonsense() -> None:
    with pytest.raises(ValueError, match="levels"):
        HoldProfile(levels=0)
    with pytest.raises(ValueError, match="repeat_period_ms"):
        HoldProfile(repeat_period_ms=0.0)


def test_header_gives_the_timing_profile() -> None:
    assert HoldProfile().to_header() == {
        "initial_delay_ms": 500.0,
        "repeat_period_ms": 33.0,
        "ms_per_level": 150.0,
        "tap_ms": 500.0,
        "calibrated": False,
        "tap_wait_ms": 700.0,
        "second_press_within_ms": 150.0,
    }


# --- the hold detector --------------------------------------------------------------------


def test_a_tap_is_level_1(detector: HoldDetector, clock: FakeClock) -> None:
    [hold] = run_hold(detector, clock, "up", [0.0])
    assert hold == Hold(key="up", hold_ms=0.0, level=1, exact=False, started=0.0, repeats=0)
    assert detector.current() is None


def test_a_tap_ends_after_the_initial_delay_plus_margin(
    detector: HoldDetector, clock: FakeClock
) -> None:
    detector.press("up")
    assert detector.deadline() == pytest.approx(0.7)


def test_a_1500_ms_hold_gives_level_8_within_one_period(
    detector: HoldDetector, clock: FakeClock
) -> None:
    times = repeat_times(1.5, delay_s=0.5, period_s=0.033)
    [hold] = run_hold(detector, clock, "right", times)
    assert HoldProfile().level_for(1500.0) == 8
    assert hold.level == 8
    assert abs(hold.hold_ms - 1500.0) <= 33.0
    assert hold.exact is False
    assert hold.repeats == len(times) - 1


@given(
    length_ms=st.floats(0.0, 4000.0),
    delay_ms=st.floats(250.0, 660.0),
    period_ms=st.floats(15.0, 100.0),
)
def test_inferred_length_is_within_half_a_period(
    length_ms: float, delay_ms: float, period_ms: float
) -> None:
    profile = HoldProfile(initial_delay_ms=delay_ms, repeat_period_ms=period_ms)
    clock = FakeClock(0.0)
    detector = HoldDetector(profile, clock=clock)
    times = repeat_times(length_ms / 1000, delay_s=delay_ms / 1000, period_s=period_ms / 1000)
    [hold] = run_hold(detector, clock, "down", times)
    if len(times) == 1:
        assert hold.hold_ms == 0.0
        assert hold.level == 1
    else:
        assert abs(hold.hold_ms - length_ms) <= period_ms / 2 + 1e-6
        assert abs(hold.level - profile.level_for(length_ms)) <= 1


def test_a_second_key_ends_the_first_hold_at_once(
    detector: HoldDetector, clock: FakeClock
) -> None:
    for t in repeat_times(1.0, delay_s=0.5, period_s=0.033):
        clock.now = t
        assert detector.press("up") == []
    clock.now = 1.001
    [hold] = detector.press("left")
    assert hold.key == "up"
    assert hold.level == HoldProfile().level_for(hold.hold_ms) == 5
    current = detector.current()
    assert current is not None and current.key == "left"


def test_a_release_wins_over_inference(detector: HoldDetector, clock: FakeClock) -> None:
    for t in repeat_times(1.2, delay_s=0.5, period_s=0.033):
        clock.now = t
        detector.press("up")
    clock.now = 1.234
    [hold] = detector.release("up")
    assert hold.exact is True
    assert hold.hold_ms == pytest.approx(1234.0)
    assert hold.level == 6  # 2 + floor(734 / 150)
    assert detector.poll() == []
    assert detector.deadline() is None


def test_a_late_release_still_wins_if_poll_has_not_run(
    detector: HoldDetector, clock: FakeClock
) -> None:
    detector.press("up")
    clock.now = 0.9  # past the 0.7 s timeout, but no timer fired yet
    [hold] = detector.release("up")
    assert hold.exact is True
    assert hold.hold_ms == pytest.approx(900.0)
    assert hold.level == 4  # 2 + floor(400 / 150)


def test_a_release_of_another_key_is_ignored(detector: HoldDetector, clock: FakeClock) -> None:
    detector.press("up")
    assert detector.release("left") == []
    assert detector.release("shift") == []
    assert detector.current() is not None


def test_poll_before_the_timeout_keeps_the_hold(detector: HoldDetector, clock: FakeClock) -> None:
    detector.press("up")
    deadline = detector.deadline()
    assert deadline is not None
    clock.now = deadline - 1e-6
    assert detector.poll() == []
    clock.now = 0.55
    detector.press("up")  # first repeat: the timeout shrinks to 3 periods
    assert detector.deadline() == pytest.approx(0.55 + 0.099)
    clock.now = 0.55 + 0.098
    assert detector.poll() == []
    clock.now = 0.55 + 0.099
    assert len(detector.poll()) == 1


def test_the_repeat_timeout_has_a_floor() -> None:
    clock = FakeClock(0.0)
    detector = HoldDetector(HoldProfile(repeat_period_ms=10.0), clock=clock)
    for t in (0.0, 0.5, 0.51, 0.52):
        clock.now = t
        detector.press("up")
    assert detector.deadline() == pytest.approx(0.52 + 0.060)


@given(gaps=st.lists(st.floats(0.001, 1.0), min_size=1, max_size=30), probe=st.floats(0, 1.5))
def test_deadline_says_when_poll_ends_the_hold(gaps: list[float], probe: float) -> None:
    """A press ends the hold after its deadline, or as a second press before any repeat could come; after a
    hold its silence ended, the same key again sooner than the hold's pace is its late repeat, dropped (as
    after `poll` ends it: the tick that would have said so may come late)."""
    clock = FakeClock(0.0)
    profile = HoldProfile()
    detector = HoldDetector(profile, clock=clock)
    detector.press("up")
    started, repeats, times, tail_pace = clock.now, 0, [clock.now], None
    for gap in gaps:
        deadline = detector.deadline()
        assert deadline is not None
        clock.now += gap
        if tail_pace is not None and repeats == 0 and gap * 1000 < tail_pace:
            assert detector.press("up") == []  # a late repeat of the hold before: dropped, and its key ignored
            return
        second_press = repeats == 0 and (clock.now - started) * 1000 < profile.earliest_repeat_ms
        ends = clock.now >= deadline or second_press
        assert (detector.press("up") != []) == ends
        if ends:
            period = (times[-1] - times[1]) * 1000 / (repeats - 1) if repeats >= 2 else profile.repeat_period_ms
            silenced = clock.now >= deadline and (repeats > 0 or tail_pace is not None)
            tail_pace = min(profile.repeat_timeout_ms(period), profile.earliest_repeat_ms) if silenced else None
            started, repeats, times = clock.now, 0, [clock.now]
        else:
            repeats, times = repeats + 1, [*times, clock.now]
    deadline = detector.deadline()
    assert deadline is not None
    clock.now += probe
    assert (detector.poll() != []) == (clock.now >= deadline)


def test_the_same_key_after_the_timeout_is_a_new_hold(
    detector: HoldDetector, clock: FakeClock
) -> None:
    detector.press("up")
    clock.now = 0.8
    [tap] = detector.press("up")
    assert tap.started == 0.0 and tap.level == 1
    current = detector.current()
    assert current is not None and current.elapsed_ms == 0.0


def test_explicit_repeats_extend_and_never_start_a_hold(
    detector: HoldDetector, clock: FakeClock
) -> None:
    assert detector.press("up", repeat=True) == []
    assert detector.current() is None
    detector.press("up", repeat=False)
    clock.now = 0.9  # beyond the timeout: a legacy event would start over, a repeat extends
    assert detector.press("up", repeat=True) == []
    current = detector.current()
    assert current is not None and current.repeats == 1


def test_an_explicit_press_of_the_held_key_starts_a_new_hold(
    detector: HoldDetector, clock: FakeClock
) -> None:
    detector.press("up", repeat=False)
    clock.now = 0.1
    [first] = detector.press("up", repeat=False)
    assert first.started == 0.0
    current = detector.current()
    assert current is not None and current.elapsed_ms == 0.0


def test_current_fills_the_gauge_while_held(detector: HoldDetector, clock: FakeClock) -> None:
    assert detector.current() is None
    detector.press("right")
    clock.now = 0.2
    assert detector.current() == ActiveHold(key="right", elapsed_ms=200.0, level=1, repeats=0)
    for t in repeat_times(0.8, delay_s=0.5, period_s=0.033):
        if t:
            clock.now = t
            detector.press("right")
    clock.now = 0.8
    current = detector.current()
    assert current is not None
    assert current.level == 4  # 2 + floor(300 / 150)
    assert current.elapsed_ms == pytest.approx(800.0)


def test_reset_drops_the_hold(detector: HoldDetector, clock: FakeClock) -> None:
    detector.press("up")
    detector.reset()
    clock.now = 5.0
    assert detector.poll() == []
    assert detector.deadline() is None


def test_only_arrows_make_holds(detector: HoldDetector) -> None:
    with pytest.raises(ValueError, match="does not take 'q'"):
        detector.press("q")


# --- calibration --------------------------------------------------------------------------


def test_calibration_measures_delay_and_period() -> None:
    calibration = Calibration(HoldProfile(ms_per_level=120.0, levels=9))
    for t in repeat_times(2.0, delay_s=0.4, period_s=0.025):
        calibration.feed("up", t)
    profile = calibration.result()
    assert profile.initial_delay_ms == pytest.approx(400.0)
    assert profile.repeat_period_ms == pytest.approx(25.0)
    assert profile.calibrated is True
    assert (profile.ms_per_level, profile.levels) == (120.0, 9)
    assert profile.to_header()["calibrated"] is True


def test_calibration_period_ignores_one_stalled_gap() -> None:
    calibration = Calibration(HoldProfile())
    times = repeat_times(2.0, delay_s=0.4, period_s=0.025)
    stalled = times[:10] + [t + 0.2 for t in times[10:]]
    for t in stalled:
        calibration.feed("up", t)
    assert calibration.result().repeat_period_ms == pytest.approx(25.0)


@pytest.mark.parametrize("repeats", [0, 2])
def test_calibration_without_autorepeat_says_what_to_do(repeats: int) -> None:
    calibration = Calibration(HoldProfile())
    for t in [0.0, 0.5, 0.53][: repeats + 1]:
        calibration.feed("up", t)
    with pytest.raises(ValueError, match="no autorepeat seen: hold the key down for 2 seconds"):
        calibration.result()


def test_calibration_clamps_to_plausible_values() -> None:
    calibration = Calibration(HoldProfile())
    for t in repeat_times(2.0, delay_s=0.05, period_s=0.3):
        calibration.feed("up", t)
    profile = calibration.result()
    assert (profile.initial_delay_ms, profile.repeat_period_ms) == (150.0, 200.0)


def test_calibration_starts_over_on_another_key_or_a_long_silence() -> None:
    calibration = Calibration(HoldProfile())
    for t in (0.0, 0.3, 0.33, 0.36, 0.39):
        calibration.feed("left", t)
    start = 3.0  # a second attempt after a pause
    for t in repeat_times(2.0, delay_s=0.6, period_s=0.04):
        calibration.feed("left", start + t)
    assert calibration.result().initial_delay_ms == pytest.approx(600.0)
    calibration.feed("up", 10.0)
    assert calibration.repeats == 0


# --- tap and digits modes -----------------------------------------------------------------


def test_tapping_k_times_gives_level_k(clock: FakeClock) -> None:
    taps = TapCounter(HoldProfile(), clock=clock)
    for t in (0.0, 0.15, 0.3):
        clock.now = t
        assert taps.press("up") == []
    current = taps.current()
    assert current is not None and current.level == 3
    clock.now = 0.3 + 0.399
    assert taps.poll() == []
    assert taps.deadline() == pytest.approx(0.7)
    clock.now = 0.7
    [hold] = taps.poll()
    assert hold == Hold(key="up", hold_ms=pytest.approx(300.0), level=3, exact=False,
                        started=0.0, repeats=2)
    assert taps.current() is None and taps.deadline() is None


def test_another_arrow_commits_the_taps_at_once(clock: FakeClock) -> None:
    taps = TapCounter(HoldProfile(), clock=clock)
    taps.press("up")
    clock.now = 0.1
    taps.press("up")
    clock.now = 0.2
    [hold] = taps.press("right")
    assert (hold.key, hold.level) == ("up", 2)
    current = taps.current()
    assert current is not None and (current.key, current.level) == ("right", 1)


def test_taps_after_a_pause_start_a_new_move(clock: FakeClock) -> None:
    taps = TapCounter(HoldProfile(), clock=clock)
    taps.press("down")
    clock.now = 0.5
    [first] = taps.press("down")
    assert first.level == 1
    current = taps.current()
    assert current is not None and current.level == 1


def test_taps_cap_at_the_top_level_and_ignore_explicit_repeats(clock: FakeClock) -> None:
    taps = TapCounter(HoldProfile(levels=3), clock=clock)
    for k in range(6):
        clock.now = k * 0.1
        taps.press("left")
        taps.press("left", repeat=True)
    clock.now = 5.0
    [hold] = taps.poll()
    assert (hold.level, hold.repeats) == (3, 5)


@pytest.mark.parametrize(
    ("keys", "level"),
    [
        ([], 1),
        (["7"], 7),
        (["1", "2"], 12),
        (["9", "9"], 14),
        (["0"], 1),
        (["1", "2", "backspace"], 1),
        (["1", "3", "backspace", "1"], 11),
        (["5", "escape", "3"], 3),
    ],
)
def test_digits_then_arrow(keys: list[str], level: int, clock: FakeClock) -> None:
    digits = DigitsInput(HoldProfile(), clock=clock)
    for key in keys:
        assert digits.press(key) == []
    clock.now = 1.5
    [hold] = digits.press("up")
    assert (hold.key, hold.level, hold.exact) == ("up", level, False)
    assert digits.current() is None


def test_digits_show_the_pending_level_and_time_the_move(clock: FakeClock) -> None:
    digits = DigitsInput(HoldProfile(), clock=clock)
    clock.now = 1.0
    digits.press("4")
    clock.now = 1.25
    assert digits.current() == ActiveHold(key=None, elapsed_ms=250.0, level=4, repeats=0)
    assert digits.deadline() is None and digits.poll() == []
    clock.now = 2.0
    [hold] = digits.press("left")
    assert (hold.started, hold.hold_ms) == (1.0, pytest.approx(1000.0))
    assert digits.press("left", repeat=True) == []


@pytest.mark.parametrize(
    ("mode", "kind"), [("hold", HoldDetector), ("tap", TapCounter), ("digits", DigitsInput)]
)
def test_the_registry_builds_each_mode(mode: str, kind: type) -> None:
    made = input_mode(mode).make(HoldProfile(), FakeClock(0.0))
    assert isinstance(made, kind)
    header = made.header()
    assert header["mode"] == mode
    assert header["initial_delay_ms"] == 500.0
    assert made.release("up") == []


def test_every_mode_commits_the_same_kind_of_move() -> None:
    for mode in ("hold", "tap", "digits"):
        clock = FakeClock(0.0)
        made = input_mode(mode).make(HoldProfile(), clock)
        done = made.press("up")
        clock.now = 10.0
        done += made.poll()
        [hold] = done
        assert isinstance(hold, Hold)
        assert (hold.key, hold.level) == ("up", 1)
        assert math.isfinite(hold.hold_ms)
