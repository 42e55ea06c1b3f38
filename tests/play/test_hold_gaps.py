"""A delivery gap in a held key's autorepeats never turns one hold into several moves.

A loaded machine, an SSH hop or tmux can hold back a terminal's autorepeats for 100-400 ms. The
silence ends the hold (the release is inferred), and the repeats that follow, at autorepeat pace,
are the tail of that hold: they are dropped, never played as moves (issue 31).
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from play_fixtures import FakeClock

from irl_core.play.hold import Hold, HoldDetector, HoldProfile

PERIOD = 0.033


def feed(detector: HoldDetector, clock: FakeClock, key: str, times: list[float]) -> list[Hold]:
    """Each event at its time, with the timer's poll before it; then the silence that ends it all."""
    done: list[Hold] = []
    for t in times:
        clock.now = t
        done += detector.poll()
        done += detector.press(key)
    clock.now = times[-1] + 2.0
    done += detector.poll()
    return done


def held_with_gap(held_s: float, gap_s: float, after: int, *, burst: bool) -> list[float]:
    """A press, repeats from 500 ms to `held_s`, a gap, then `after` more repeats (bunched if `burst`)."""
    times = [0.0] + [0.5 + k * PERIOD for k in range(int((held_s - 0.5) / PERIOD) + 1)]
    resume = times[-1] + gap_s
    step = 0.001 if burst else PERIOD
    return times + [resume + k * step for k in range(after)]


def test_the_issues_case_is_one_move() -> None:
    """Press, repeats for 400 ms after the delay, a 150 ms gap, 15 more repeats: was 1 + 15 moves."""
    clock = FakeClock(0.0)
    times = [0.0] + [0.5 + k * PERIOD for k in range(13)]
    times += [times[-1] + 0.15 + k * PERIOD for k in range(15)]
    moves = feed(HoldDetector(HoldProfile(), clock=clock), clock, "right", times)
    assert len(moves) == 1, [(m.level, m.hold_ms) for m in moves]


@settings(max_examples=200, deadline=None)
@given(held_s=st.floats(0.55, 2.0), gap_s=st.floats(0.1, 0.4), after=st.integers(2, 40),
       burst=st.booleans())
def test_a_gap_of_100_to_400_ms_mid_hold_never_makes_a_second_move(
        held_s: float, gap_s: float, after: int, burst: bool) -> None:
    clock = FakeClock(0.0)
    times = held_with_gap(held_s, gap_s, after, burst=burst)
    moves = feed(HoldDetector(HoldProfile(), clock=clock), clock, "up", times)
    assert len(moves) == 1
    assert moves[0].hold_ms >= times[-after - 1] * 1000, "the move keeps the length held before the gap"


def test_a_new_press_after_a_hold_is_still_a_move() -> None:
    """A person who lets go and presses the same arrow again, and holds it, makes a second move."""
    clock = FakeClock(0.0)
    first = held_with_gap(1.0, 0.0, 0, burst=False)
    second_press = first[-1] + 0.25
    second = [second_press] + [second_press + 0.5 + k * PERIOD for k in range(10)]
    moves = feed(HoldDetector(HoldProfile(), clock=clock), clock, "up", first + second)
    assert len(moves) == 2 and moves[1].level > 1


def test_a_tap_after_a_hold_is_still_a_move() -> None:
    clock = FakeClock(0.0)
    times = held_with_gap(1.0, 0.0, 0, burst=False)
    moves = feed(HoldDetector(HoldProfile(), clock=clock), clock, "up", times + [times[-1] + 0.3])
    assert [m.level for m in moves][1:] == [1]


def test_another_arrow_after_a_gap_is_a_move_of_its_own() -> None:
    clock = FakeClock(0.0)
    detector = HoldDetector(HoldProfile(), clock=clock)
    moves = feed(detector, clock, "up", held_with_gap(1.0, 0.2, 5, burst=False))
    clock.now += 0.01
    moves += detector.press("left")
    clock.now += 2.0
    moves += detector.poll()
    assert [m.key for m in moves] == ["up", "left"]
