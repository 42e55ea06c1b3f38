"""`careful play --world reach` in a real terminal (tmux): space held as a terminal repeats it launches a reach,
written as a step line the reach reader reads back."""

from __future__ import annotations

import time
from pathlib import Path

from tmux_terminal import TIMEOUT_S, needs_tmux, terminal

from irl_core.recordings.reach_reader import ReachRecording, read_reach_recording

pytestmark = needs_tmux


def written_trial(out: Path, timeout: float = TIMEOUT_S) -> ReachRecording:
    """The reach recording in `out`, once it holds a whole step line."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        files = list(out.glob("*.jsonl")) if out.exists() else []
        if files and '"step"' in (text := files[0].read_text()) and text.endswith("\n"):
            return read_reach_recording(files[0])
        time.sleep(0.05)
    raise AssertionError(f"no reach recorded in {out}")


def test_holding_space_in_a_terminal_launches_a_recorded_reach(tmp_path: Path) -> None:
    out = tmp_path / "rec"
    with terminal(tmp_path, ["play", "--world", "reach", "--out", str(out), "--player", "e2e", "--seed", "3",
                             "--trials", "1"]) as session:
        session.wait_for("Trial 1 of 1")
        session.send("Right", "Right")
        session.wait_for("Aim (208, 80)")
        session.hold("Space", 0.8)
        session.wait_for("Block done.")
        recording = written_trial(out)
        session.send("q")
        session.wait_for("recorded to")
        assert session.wait_exit() == 0
    (step,) = recording.steps
    assert recording.header.player == "e2e" and recording.header.seed == 3
    assert step.aim == (208.0, 80.0) and not step.hold_exact
    # The press, 500 ms of silence, then 0.8 s of repeats: about 1.3 s, inferred. A busy machine's gap in
    # the repeats can end it sooner, never before the first repeat.
    assert 500 <= step.duration_ms <= 1400
