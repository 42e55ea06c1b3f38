"""`careful play` in a real terminal (tmux): hold an arrow by autorepeat, quit, close the terminal."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from irl_core.demonstrations import Recording, read_recording

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")

WORLD = """\
name = "e2e"
layout = \"\"\"
......
......
......
.CCCCG
\"\"\"
levels = 14
slip = "none"
start = [0, 0]
[rewards]
C = -1000.0
G = 100.0
"""


class Session:
    """`careful play` running in a detached 100x35 tmux session, on a tmux server of its own."""

    def __init__(self, tmp_path: Path) -> None:
        self.name = f"careful-e2e-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        self.out = tmp_path / "rec"
        world = tmp_path / "e2e.toml"
        world.write_text(WORLD)
        command = (f"{sys.executable} -m careful_tui.cli play --world {world} --out {self.out} "
                   f"--player e2e --seed 3; sleep 5")
        self.tmux("new-session", "-d", "-s", self.name, "-x", "100", "-y", "35", command)
        self.socket = Path(self.tmux("display-message", "-p", "#{socket_path}").strip())
        # Keys go through one control-mode client: a write per key instead of a process per key,
        # so that the 33 ms autorepeat rhythm survives a busy machine.
        self.control = subprocess.Popen(["tmux", "-L", self.name, "-C", "attach", "-t", self.name],
                                        stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)

    def tmux(self, *args: str) -> str:
        command = ["tmux", "-L", self.name, *args]
        return subprocess.run(command, check=True, capture_output=True, text=True).stdout

    def screen(self) -> str:
        return self.tmux("capture-pane", "-p", "-t", self.name)

    def wait_for(self, text: str, timeout: float = 15.0) -> str:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            screen = self.screen()
            if text in screen:
                return screen
            time.sleep(0.05)
        raise AssertionError(f"{text!r} never appeared; the screen was:\n{self.screen()}")

    def send(self, key: str) -> None:
        assert self.control.stdin is not None
        self.control.stdin.write(f"send-keys -t {self.name} {key}\n")
        self.control.stdin.flush()

    def hold(self, key: str, seconds: float, *, delay: float = 0.5, period: float = 0.033) -> None:
        """A press, `delay` of silence, then autorepeats every `period` until `seconds` after the delay."""
        self.send(key)
        time.sleep(delay)
        start = time.monotonic()
        n = 0
        while (due := start + n * period) - start <= seconds:
            time.sleep(max(0.0, due - time.monotonic()))
            self.send(key)
            n += 1

    def recording(self, timeout: float = 10.0) -> Recording:
        """The session file, once it ends with an episode end."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            files = list(self.out.glob("*.jsonl")) if self.out.exists() else []
            if files and '"episode_end"' in files[0].read_text():
                return read_recording(files[0])
            time.sleep(0.05)
        raise AssertionError(f"no finished recording in {self.out}; the screen was:\n{self.screen()}")

    def kill(self) -> None:
        """Close the terminal: the session, and with it this test's tmux server."""
        subprocess.run(["tmux", "-L", self.name, "kill-server"], capture_output=True)
        self.control.stdin.close()
        self.control.wait(timeout=10)
        self.socket.unlink(missing_ok=True)


def test_holding_an_arrow_in_a_terminal_records_its_carefulness(tmp_path: Path) -> None:
    session = Session(tmp_path)
    try:
        session.wait_for("carefulness")
        session.hold("Right", 1.0)
        session.wait_for("step 1/200")
        session.send("q")
        rec = session.recording()
        session.wait_for("recorded to")
    finally:
        session.kill()
    (step,) = rec.steps
    assert step.direction == "right" and step.state == (0, 0) and step.next_state == (0, 1)
    # The press, 500 ms, then ~1 s of repeats: about 1.5 s, level 8 with the default profile.
    assert 1350 <= step.hold_ms <= 1700 and not step.hold_exact
    assert 7 <= step.carefulness <= 9
    (end,) = rec.episode_ends
    assert end.outcome == "quit" and end.steps == 1 and end.score == 200 - step.carefulness
    assert rec.header.input["mode"] == "hold" and rec.header.player == "e2e"


def test_closing_the_terminal_mid_episode_records_quit(tmp_path: Path) -> None:
    session = Session(tmp_path)
    try:
        session.wait_for("carefulness")
        session.send("Down")
        session.wait_for("step 1/200")
    finally:
        session.kill()
    rec = session.recording()
    assert [(s.direction, s.carefulness, s.hold_ms) for s in rec.steps] == [("down", 1, 0.0)]
    assert [e.outcome for e in rec.episode_ends] == ["quit"]
