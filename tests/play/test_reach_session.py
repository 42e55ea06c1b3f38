"""The reach session: refusals are never recorded, trials read back through the reach reader, the endpoints
scatter as the spread law says, a hold is exact with releases and inferred (and marked so) without."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from irl_core.play.reach_session import (
    ReachOptions,
    new_reach_session,
    starting_aim,
    too_quick_words,
    too_slow_words,
)
from irl_core.recordings.reach_reader import read_reach_recording
from irl_core.worlds.reach import REACH_WORLDS
from tests.play_fixtures import FakeClock

WORLD = REACH_WORLDS["reach"]


def session(tmp_path, *, trials=5, world=WORLD, seed=3):
    clock = FakeClock()
    return new_reach_session(world, out=tmp_path / "rec", seed=seed, app_version="test",
                             options=ReachOptions(player="ada", trials=trials), clock=clock), clock


def exact_reach(s, clock, ms, key="space"):
    s.press(key, at=clock.now, repeat=False)
    clock.advance(ms / 1000)
    return s.release(key, at=clock.now)


def legacy_reach(s, clock, repeats, *, delay=0.5, period=0.033):
    """A key held as a legacy terminal reports it: a press, then `repeats` autorepeats after the delay, then
    silence until the session's deadline passes."""
    s.press("space", at=clock.now)
    clock.advance(delay)
    for k in range(repeats):
        if k:
            clock.advance(period)
        s.press("space", at=clock.now)
    clock.now = s.deadline() + 0.001
    return s.tick(until=clock.now)


def test_the_aim_starts_at_the_target_and_is_kept_in_the_field(tmp_path):
    s, _ = session(tmp_path)
    assert s.view().aim == (200.0, 80.0)  # the centre of G, the circle worth the most
    s.move_aim(-1000, 5)
    assert s.aim == (0.0, 85.0)
    s.move_aim(10_000, 10_000)
    assert s.aim == WORLD.field


def test_a_field_of_penalties_only_starts_the_aim_at_its_centre():
    world = WORLD.model_copy(update={"regions": tuple(r.model_copy(update={"points": -5.0}) for r in WORLD.regions)})
    assert starting_aim(world) == (200.0, 150.0)


def test_refused_reaches_are_said_and_never_recorded(tmp_path):
    s, clock = session(tmp_path)
    assert exact_reach(s, clock, 100) is None
    assert s.view().message.text == too_quick_words(WORLD, inferred=False)
    assert s.view().message.kind == "warn"
    assert exact_reach(s, clock, 1600) is None
    assert s.view().message.text == too_slow_words(WORLD)
    assert "at most 1500 ms" in s.view().message.text
    assert s.recorder.paths == []
    assert s.view().trial == 1
    step = exact_reach(s, clock, 600)
    assert step is not None and step.episode == 0  # the refused reaches took no trial's number
    s.quit()
    assert [line.episode for line in read_reach_recording(s.recorder.paths[-1]).steps] == [0]


def test_recorded_trials_read_back_through_the_reach_reader(tmp_path):
    s, clock = session(tmp_path, trials=4)
    made = []
    for ms, dx in ((400, 0), (800, 6), (1500, -4), (150, 2)):
        s.move_aim(dx, 0)
        made.append(exact_reach(s, clock, ms))
    assert s.done and s.view().done
    # Done: nothing more is taken, and the file is closed with every trial in it.
    assert exact_reach(s, clock, 600) is None
    recording = read_reach_recording(s.recorder.paths[-1])
    assert recording.steps == made
    assert recording.header.world == WORLD and recording.header.player == "ada" and recording.header.seed == 3
    assert [step.duration_ms for step in recording.steps] == pytest.approx([400, 800, 1500, 150])
    assert recording.steps[-1].score == pytest.approx(sum(step.reward for step in made))
    assert recording.warnings == []


def test_the_same_seed_and_keys_land_the_same_reaches(tmp_path):
    ends = []
    for run in range(2):
        s, clock = session(tmp_path / str(run), trials=3, seed=11)
        ends.append([exact_reach(s, clock, ms).endpoint for ms in (300, 700, 1100)])
    assert ends[0] == ends[1]


def test_endpoints_scatter_as_the_spread_law_says(tmp_path):
    trials = 1500
    s, clock = session(tmp_path, trials=trials, seed=2)
    for _ in range(trials):
        exact_reach(s, clock, 600)
    ends = np.array([step.endpoint for step in read_reach_recording(s.recorder.paths[-1]).steps])
    # By hand: the aim (200, 80) is 200 from the start (200, 280); a 0.6 s reach: sd = 2 + 0.05 * 200 / 0.6.
    expected = 2 + 0.05 * 200 / 0.6
    misses = ends - np.array([200.0, 80.0])
    # The sample sd of n normal draws is within 3 * sd / sqrt(2n) (about 5%) of the truth nearly always.
    assert misses.std(axis=0, ddof=1) == pytest.approx([expected, expected], rel=0.05)
    assert np.all(np.abs(misses.mean(axis=0)) < 3 * expected / math.sqrt(trials))
    # The world's own function says the same (the check above is the independent one).
    assert float(WORLD.sd((200, 80), 600)) == pytest.approx(expected)


def test_the_ring_shrinks_while_the_key_is_held(tmp_path):
    s, clock = session(tmp_path)
    assert s.ring_sd() is None and s.view().holding is None
    s.press("space", at=clock.now, repeat=False)
    rings = []
    for ms in (0, 100, 150, 600, 1500, 2000):
        clock.now = 1000.0 + ms / 1000
        rings.append(s.ring_sd())
    law = [float(WORLD.sd(s.aim, min(max(ms, 150), 1500))) for ms in (0, 100, 150, 600, 1500, 2000)]
    assert rings == pytest.approx(law)
    assert rings[2] > rings[3] > rings[4]  # shrinking within the limits, held at the nearest allowed outside
    assert s.view().holding.within == "long"
    clock.now = 1000.05
    assert s.view().holding.within == "short"


def test_an_exact_hold_is_recorded_exact(tmp_path):
    s, clock = session(tmp_path)
    step = exact_reach(s, clock, 700)
    assert step.hold_exact is True and step.duration_ms == pytest.approx(700)


def test_a_hold_inferred_from_autorepeats_is_recorded_as_inferred(tmp_path):
    s, clock = session(tmp_path)
    step = legacy_reach(s, clock, repeats=10)
    # The press, the first repeat at 500 ms, nine more 33 ms apart: the last repeat at 797 ms plus half a period.
    assert step is not None and step.hold_exact is False
    assert step.duration_ms == pytest.approx(500 + 9 * 33 + 33 / 2)
    s.quit()
    assert read_reach_recording(s.recorder.paths[-1]).steps[0].hold_exact is False


def test_a_tap_in_a_legacy_terminal_is_too_quick_and_says_why(tmp_path):
    s, clock = session(tmp_path)
    assert legacy_reach(s, clock, repeats=0) is None
    assert s.view().message.text == too_quick_words(WORLD, inferred=True)
    assert "repeats" in s.view().message.text
    assert s.steps == []


def test_without_releases_the_ring_shows_no_more_than_the_repeats_say(tmp_path):
    s, clock = session(tmp_path)
    s.press("space", at=clock.now)
    clock.advance(0.5)
    s.press("space", at=clock.now)  # the first repeat, at 500 ms
    clock.advance(0.09)  # no repeat for 90 ms: the key may be up, so the hold counts to 533 ms at most
    assert s.view().holding.held_ms == pytest.approx(533)


def test_the_aim_does_not_move_while_a_reach_is_timed(tmp_path):
    s, clock = session(tmp_path)
    s.press("space", at=clock.now, repeat=False)
    s.move_aim(10, 0)
    assert s.aim == (200.0, 80.0)


def test_a_cancelled_hold_is_no_trial(tmp_path):
    s, clock = session(tmp_path)
    s.press("space", at=clock.now, repeat=False)
    clock.advance(0.4)
    assert s.cancel_hold("window too small")
    assert s.release("space", at=clock.now) is None
    assert s.steps == [] and "window too small" in s.view().message.text


def test_own_noise_takes_the_front_ends_reach(tmp_path):
    own = WORLD.model_copy(update={"noise": "own"})
    s, clock = session(tmp_path, world=own)
    assert s.press("space", at=clock.now, repeat=False) is None and not s.entering()  # no hold times an own reach
    assert s.launch_own((190.0, 85.0), 100.0) is None
    assert s.view().message.text == too_quick_words(own, inferred=False)
    step = s.launch_own((190.0, 85.0), 640.0)
    assert step.endpoint == (190.0, 85.0) and step.regions == ("G", "C") and step.hold_exact
    assert step.reward == pytest.approx(100 - 500 - 20 * 0.64)
    with pytest.raises(ValueError, match="finite"):
        s.launch_own((math.nan, 1.0), 600.0)
    s.quit()
    assert read_reach_recording(s.recorder.paths[-1]).steps == [step]


def test_own_reaches_are_refused_on_a_simulated_world(tmp_path):
    s, _ = session(tmp_path)
    with pytest.raises(ValueError, match="own"):
        s.launch_own((190.0, 85.0), 600.0)


def test_a_trial_that_cannot_be_written_stops_the_block(tmp_path):
    s, clock = session(tmp_path)
    (tmp_path / "rec").write_text("a file where the folder should be")
    assert exact_reach(s, clock, 600) is None
    assert s.done and s.write_error is not None and s.steps == []
    assert s.view().message.kind == "warn"


def test_a_block_needs_a_trial():
    with pytest.raises(ValueError, match="at least 1"):
        ReachOptions(trials=0)


def test_a_lone_late_repeat_after_a_launch_is_dropped_without_a_word(tmp_path):
    s, clock = session(tmp_path)
    step = legacy_reach(s, clock, repeats=10)
    clock.advance(0.05)  # the key was still down: one more repeat, held back by a busy machine
    assert legacy_reach(s, clock, repeats=0) is None
    assert s.view().message.text.startswith("Landed") and s.steps == [step]
    clock.advance(2.0)  # a tap of its own, long after: too quick, and said
    assert legacy_reach(s, clock, repeats=0) is None
    assert s.view().message.text == too_quick_words(WORLD, inferred=True)


@pytest.mark.parametrize("first_repeat", [0.45, 0.75, 1.1])
def test_a_late_first_repeat_still_times_the_hold_from_its_press(tmp_path, first_repeat):
    # A slow keyboard or a busy machine: the first autorepeat comes late, the rest 33 ms apart; the screen
    # ticks every 10 ms. The hold is one reach, timed from the press, not a string of refused taps.
    s, clock = session(tmp_path)
    start = clock.now
    s.press("space", at=start)
    repeats = [start + first_repeat + 0.033 * k for k in range(8)]
    launched = []
    while clock.now < start + 3.0:
        clock.advance(0.01)
        while repeats and repeats[0] <= clock.now:
            launched.append(s.press("space", at=repeats.pop(0)))
        launched.append(s.tick(until=clock.now))
    (step,) = [step for step in launched if step is not None]
    assert step.duration_ms == pytest.approx((first_repeat + 7 * 0.033 + 0.033 / 2) * 1000, abs=1)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.floats(-500, 500), st.floats(-500, 500), st.floats(0, 3000)), min_size=1, max_size=8))
def test_any_play_records_exactly_the_reaches_within_the_limits(tmp_path_factory, plays):
    tmp_path = tmp_path_factory.mktemp("any")
    s, clock = session(tmp_path, trials=len(plays))
    for dx, dy, ms in plays:
        s.move_aim(dx, dy)
        assert 0 <= s.aim[0] <= WORLD.field[0] and 0 <= s.aim[1] <= WORLD.field[1]
        exact_reach(s, clock, ms)
        clock.advance(1.0)
    s.quit()
    within = [ms for _, _, ms in plays if WORLD.min_ms <= round(ms, 3) <= WORLD.max_ms]
    recorded = read_reach_recording(s.recorder.paths[0]).steps if s.recorder.paths else []
    assert [step.duration_ms for step in recorded] == pytest.approx(within, abs=1e-3)
    assert [step.episode for step in recorded] == list(range(len(within)))
