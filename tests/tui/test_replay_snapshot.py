"""How the replay screen looks mid-session, at a slip, in an 80x24 terminal (an SVG snapshot).

Update the snapshot after an intended change with `pytest tests/tui --snapshot-update`.
"""

from __future__ import annotations

from pathlib import Path

from careful_tui.app import make_replay_app
from irl_core.demonstrations import read_recording

SAMPLE = Path(__file__).parents[2] / "recordings" / "sample-expert-paper.jsonl"


def test_replay_screen_at_a_slip(snap_compare) -> None:
    # Paused, and a frame outlasts the test: only the keys move the replay.
    app = make_replay_app(read_recording(SAMPLE), frame_seconds=3600)
    # The second episode's fourth step: down, at level 3, slipped up.
    keys = ["up", *["right"] * 7]
    assert snap_compare(app, press=keys, terminal_size=(80, 24))
    frame = app.first_screen.cursor.frame
    assert (frame.index, frame.t, frame.phase) == (1, 3, "after") and frame.step.slipped
