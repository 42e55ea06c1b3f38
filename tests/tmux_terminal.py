"""A command in a real terminal for tests: a detached tmux session on a tmux server of its own.

Keys go through one control-mode client (one write per key, so an autorepeat rhythm survives
a busy machine; resizes go the same way, so they stay in order with the keys) and the screen
is read with `capture-pane`, polling with timeouts rather than sleeping. The pane stays after
the program ends (`remain-on-exit`), so its last screen can still be read; the shell that runs
it writes its exit status to a file. Used by the play and replay tests in tui/ and hardening/.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

needs_tmux = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")

SIZE = (100, 35)
# How long a wait for a screen or an exit may last before the test fails: a bound on an event, never a pause. A
# loaded machine (load 4-5 on 2 cores) takes Textual's start to 20 s and more, so the bound is far beyond that.
TIMEOUT_S = 120.0



class Terminal:
    """A command running in a detached tmux session, on a tmux server of its own."""

    def __init__(self, cwd: Path, args: list[str], *, size: tuple[int, int] = SIZE,
                 env: dict[str, str] | None = None) -> None:
        self.name = f"careful-abuse-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        self.socket: Path | None = None
        self.control: subprocess.Popen | None = None
        conf = cwd / f"{self.name}.conf"
        # status off: the pane is the whole window, so a resize to 60x20 gives the app 60x20.
        conf.write_text("set -g remain-on-exit on\nset -g status off\n")
        # The shell writes the exit status to a file: tmux 3.3 does not report a status of 0, and
        # a message on the screen would overwrite the last screen the program drew.
        self.status_file = cwd / f"{self.name}.status"
        assignments = [f"{name}={shlex.quote(value)}" for name, value in (env or {}).items()]
        command = (" ".join([*assignments, shlex.join([sys.executable, "-m", "careful_tui.cli", *args])])
                   + f"; echo $? > {shlex.quote(str(self.status_file))}")
        width, height = size
        self.tmux("-f", str(conf), "new-session", "-d", "-s", self.name, "-x", str(width), "-y", str(height),
                  "-c", str(cwd), command)
        self.socket = Path(self.tmux("display-message", "-p", "#{socket_path}").strip())
        self.control = subprocess.Popen(["tmux", "-L", self.name, "-C", "attach", "-t", self.name],
                                        stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)

    def tmux(self, *args: str) -> str:
        return subprocess.run(["tmux", "-L", self.name, *args], check=True, capture_output=True, text=True).stdout

    def command(self, line: str) -> None:
        """One tmux command through the control client (ordered with the keys sent before it)."""
        assert self.control is not None and self.control.stdin is not None
        self.control.stdin.write(line + "\n")
        self.control.stdin.flush()

    def send(self, *keys: str) -> None:
        """Keys by tmux name ("Right", "Space", "q"), in one write."""
        self.command(f"send-keys -t {self.name} {' '.join(keys)}")

    def send_bytes(self, data: bytes) -> None:
        """Raw bytes, as a terminal would send them (`send-keys -H`)."""
        self.command(f"send-keys -t {self.name} -H {' '.join(f'{b:02x}' for b in data)}")

    def resize(self, width: int, height: int) -> None:
        self.command(f"resize-window -t {self.name} -x {width} -y {height}")

    def repeat(self, key: str, seconds: float, *, period: float = 0.033) -> float:
        """Autorepeats of `key` every `period` for `seconds` (each on time, not after the last); returns when
        the last was sent (time.monotonic)."""
        start = last = time.monotonic()
        n = 1
        while (due := start + n * period) - start <= seconds:
            time.sleep(max(0.0, due - time.monotonic()))
            self.send(key)
            last = time.monotonic()
            n += 1
        return last

    def hold(self, key: str, seconds: float, *, delay: float = 0.5) -> float:
        """Hold `key` as a terminal reports it: a press, `delay` of silence, then autorepeats. Returns the
        seconds from the press to the last repeat as sent: on a busy machine longer than asked."""
        pressed = time.monotonic()
        self.send(key)
        time.sleep(delay)
        self.send(key)
        return self.repeat(key, seconds) - pressed

    def screen(self) -> str:
        return self.tmux("capture-pane", "-p", "-t", self.name)

    def history(self) -> str:
        """Everything the pane printed, scrolled-off lines included, wrapped lines joined."""
        return self.tmux("capture-pane", "-p", "-J", "-S", "-", "-t", self.name)

    def wait_for(self, want: str | Callable[[str], bool], timeout: float = TIMEOUT_S) -> str:
        """The screen, once it contains `want` (or `want(screen)` is true)."""
        check = want if callable(want) else (lambda screen: want in screen)
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if check(screen := self.screen()):
                return screen
            time.sleep(0.05)
        size = self.tmux("display-message", "-p", "-t", self.name, "#{pane_width}x#{pane_height}").strip()
        raise AssertionError(f"{want!r} never appeared; the {size} screen was:\n{self.screen()}")

    def pid(self) -> int:
        """The program's process id: the one child of the pane's shell."""
        shell = int(self.tmux("display-message", "-p", "-t", self.name, "#{pane_pid}"))
        children = Path(f"/proc/{shell}/task/{shell}/children")
        if children.exists():
            (child,) = children.read_text().split()
        else:
            (child,) = subprocess.run(["pgrep", "-P", str(shell)], check=True, capture_output=True,
                                      text=True).stdout.split()
        return int(child)

    def wait_exit(self, timeout: float = TIMEOUT_S) -> int:
        """The program's exit status once it has ended (128 + N when signal N killed it)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.status_file.exists() and (status := self.status_file.read_text().strip()):
                return int(status)
            time.sleep(0.05)
        raise AssertionError(f"the program never ended; the screen was:\n{self.screen()}")

    def close(self) -> None:
        """Kill the tmux server (and with it the program) and remove its socket."""
        subprocess.run(["tmux", "-L", self.name, "kill-server"], capture_output=True, check=False)
        if self.control is not None:
            try:
                self.control.stdin.close()
            except BrokenPipeError:
                pass
            try:
                self.control.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.control.kill()
                self.control.wait()
        if self.socket is not None:
            self.socket.unlink(missing_ok=True)


@contextmanager
def terminal(cwd: Path, args: list[str], *, size: tuple[int, int] = SIZE,
             env: dict[str, str] | None = None) -> Iterator[Terminal]:
    term = None
    try:
        term = Terminal(cwd, args, size=size, env=env)
        yield term
    finally:
        if term is not None:
            term.close()
