"""How the replay screen looks in an 80x24 terminal (SVG snapshots): mid-session at a slip, and on
the second of two files, recorded in another world.

Update the snapshot after an intended change with `pytest tests/tui --snapshot-update`.
"""

from __future__ import annotations

from pathlib import Path

from careful_tui.app import make_replay_app
from irl_core.recordings.demonstrations import read_recording

SAMPLE = Path(__file__).parents[2] / "recordings" / "samples" / "sample-expert-paper.jsonl"


def test_replay_screen_at_a_slip(snap_compare) -> None:
    # Paused, and a frame outlasts the test: only the keys move the replay.
    app = make_replay_app(read_recording(SAMPLE), frame_seconds=3600)
    # The second episode's fourth step: down, at level 3, slipped up.
    keys = ["up", *["right"] * 7]
    assert snap_compare(app, press=keys, terminal_size=(80, 24))
    frame = app.first_screen.cursor.frame
    assert (frame.index, frame.t, frame.phase) == (1, 3, "after") and frame.step.slipped


def test_replay_screen_of_the_second_of_two_files_in_another_world(snap_compare) -> None:
    # The sample (paper world), then a recording in the mud world: PgDn goes to it.
    other = Path(__file__).parents[1] / "corpus" / "recordings" / "different_world_b.jsonl"
    app = make_replay_app(read_recording(SAMPLE), read_recording(other), frame_seconds=3600)
    assert snap_compare(app, press=["pagedown", "right", "right"], terminal_size=(80, 24))
    assert app.first_screen.files.place == (1, 2) and app.first_screen.world.name == "mud"
