"""`careful play` in a real terminal (tmux): hold an arrow by autorepeat, quit, close the terminal."""

from __future__ import annotations

import time
from pathlib import Path

from play_fixtures import corner_world_toml
from tmux_terminal import TIMEOUT_S, needs_tmux, terminal

from irl_core.recordings.demonstrations import Recording, read_recording

pytestmark = needs_tmux

WORLD = corner_world_toml("e2e")


def play(tmp_path: Path):
    """`careful play` of the e2e world in a terminal; recordings go to tmp_path/rec."""
    world = tmp_path / "e2e.toml"
    world.write_text(WORLD)
    return terminal(tmp_path, ["play", "--world", str(world), "--out", str(tmp_path / "rec"),
                               "--player", "e2e", "--seed", "3"])


def finished_recording(out: Path, timeout: float = TIMEOUT_S) -> Recording:
    """The session file in `out`, once it ends with an episode end."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        files = list(out.glob("*.jsonl")) if out.exists() else []
        if files and '"episode_end"' in files[0].read_text():
            return read_recording(files[0])
        time.sleep(0.05)
    raise AssertionError(f"no finished recording in {out}")


def test_holding_an_arrow_in_a_terminal_records_its_carefulness(tmp_path: Path) -> None:
    with play(tmp_path) as session:
        session.wait_for("carefulness")
        held_s = session.hold("Right", 1.0)
        session.wait_for("step 1/200")
        session.send("q")
        rec = finished_recording(tmp_path / "rec")
        session.wait_for("recorded to")
    (step,) = rec.steps
    assert step.direction == "right" and step.state == (0, 0) and step.next_state == (0, 1)
    # The press, 500 ms, then ~1 s of repeats: about 1.5 s, level 8 with the default profile. The hold runs from
    # the press to the last repeat as the program read them: within the driver's own span (longer than 1.5 s
    # on a busy machine), give or take a repeat period and the time keys take to arrive.
    assert held_s * 1000 - 150 <= step.hold_ms <= held_s * 1000 + 200 and not step.hold_exact
    assert step.hold_ms >= 1350 and step.carefulness >= 7
    (end,) = rec.episode_ends
    assert end.outcome == "quit" and end.steps == 1 and end.score == 200 - step.carefulness
    assert rec.header.input["mode"] == "hold" and rec.header.player == "e2e"


def test_closing_the_terminal_mid_episode_records_quit(tmp_path: Path) -> None:
    with play(tmp_path) as session:
        session.wait_for("carefulness")
        session.send("Down")
        session.wait_for("step 1/200")
    rec = finished_recording(tmp_path / "rec")
    assert [(s.direction, s.carefulness, s.hold_ms) for s in rec.steps] == [("down", 1, 0.0)]
    assert [e.outcome for e in rec.episode_ends] == ["quit"]
