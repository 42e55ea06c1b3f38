"""The play session's calls as a browser makes them: exact press and release times, a hold
cancelled when the window loses focus, the board hidden, a block's end, calibration's rules and
a disk that fills."""

from __future__ import annotations

from pathlib import Path

import pytest
from play_fixtures import FakeClock, corner_world

from irl_core.play.session import Message, PlayOptions, PlaySession, new_session
from irl_core.recordings.demonstrations import read_recording
from irl_core.recordings.writer import RecordingWriter


def session(tmp_path: Path, **options) -> tuple[PlaySession, FakeClock]:
    clock = FakeClock()
    made = new_session(corner_world(), out=tmp_path / "rec", seed=1, options=PlayOptions(**options), clock=clock,
                       app_version="test")
    made.start()
    return made, clock


def recorded(made: PlaySession) -> list[tuple]:
    (path,) = made.recorder.paths
    return [(s.direction, s.carefulness, s.hold_ms, s.hold_exact) for s in read_recording(path).steps]


def test_a_press_and_a_release_at_their_own_times_record_the_hold_exactly(tmp_path: Path) -> None:
    made, clock = session(tmp_path)
    made.press("down", at=1000.0, repeat=False)
    made.press("down", at=1000.5, repeat=True)
    assert made.view().hold is not None and made.entering()
    clock.now = 1003.0  # handled late: the times given count, not the clock
    played = made.release("down", at=1000.8125)
    made.quit()
    assert [move.step.direction for move in played.moves] == ["down"]
    assert recorded(made) == [("down", 4, 812.5, True)]


def test_a_hold_cancelled_when_focus_is_lost_makes_no_move_and_its_key_is_ignored_till_pressed_again(tmp_path: Path) -> None:
    made, clock = session(tmp_path)
    made.press("down", at=1000.0, repeat=False)
    assert made.cancel_hold("window lost focus")
    assert made.view().message == Message("Move cancelled (window lost focus).", "warn")
    assert made.press("down", at=1000.5, repeat=True).moves == () and made.view().hold is None
    clock.now = 1005.0
    assert made.tick().moves == ()
    made.press("down", at=1005.0, repeat=False)
    made.release("down", at=1005.1)
    assert not made.cancel_hold("window lost focus")  # nothing being entered
    made.quit()
    assert recorded(made) == [("down", 1, 100.0, True)]


def test_no_key_moves_while_the_board_is_hidden(tmp_path: Path) -> None:
    made, clock = session(tmp_path)
    made.press("down", at=1000.0)
    assert made.set_board_visible(False, why="window too small")
    made.press("right", at=1000.1)
    clock.now = 1002.0
    assert made.tick().moves == ()
    assert not made.set_board_visible(True)
    made.press("right", at=1002.0)
    clock.now = 1004.0
    made.tick()
    made.quit()
    assert [step[0] for step in recorded(made)] == ["right"]


def test_a_block_of_set_episodes_ends_after_its_last(tmp_path: Path) -> None:
    made, clock = session(tmp_path, input_mode="digits", episodes=1, episodes_done=2, episode_word="Episode")
    assert made.names.number(made.view().episode) == "3 of 3"
    for key in ("down", "down", "down", "right", "right", "right", "right", "right", "down"):
        made.press(key)
    view = made.view()
    assert not view.live and view.last_end.outcome == "terminal" and view.all_played
    assert made.next_episode() and not made.view().live  # the block is over: nothing begins


def test_calibration_is_offered_only_when_it_can_apply(tmp_path: Path) -> None:
    tap, _ = session(tmp_path / "tap", input_mode="tap")
    assert not tap.view().calibration_offered and "tap input does not time holds" in tap.calibration_refused()
    with pytest.raises(ValueError, match="does not time holds"):
        tap.start_calibration()
    hold, clock = session(tmp_path / "hold")
    assert hold.view().calibration_offered and hold.calibration_refused() is None
    hold.press("down")
    clock.advance(1.0)
    hold.tick()
    assert not hold.view().calibration_offered
    assert hold.calibration_refused() == "Calibrate before an episode's first move or after it ends."


def test_a_full_disk_stops_the_session_and_keeps_what_was_written(tmp_path: Path, monkeypatch) -> None:
    made, clock = session(tmp_path, input_mode="digits")
    made.press("down")

    def full(self, step):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(RecordingWriter, "write_step", full)
    played = made.press("down")
    assert played.stopped and played.moves == ()
    assert made.write_error.errno == 28 and not made.view().live
    assert made.press("down").moves == ()  # nothing more is played
    made.quit()
    made.quit()
    assert [step[0] for step in recorded(made)] == ["down"]
