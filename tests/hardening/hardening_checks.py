"""What every hardening case checks: the exit status, one line on stderr, unchanged inputs, no control characters."""

from __future__ import annotations

import hashlib
import re
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest

from careful_tui.cli import main
from irl_core.players.experts import optimal_policy, rollouts, write_rollouts
from irl_core.worlds.mdp import build_mdp
from irl_core.worlds.world import BUILTIN_WORLDS

# Any C0 control but the newline, DEL, and the C1 controls: none may reach a terminal.
RAW_CONTROL = re.compile("[\x00-\x09\x0b-\x1f\x7f-\x9f]")


def digest(*paths: Path) -> dict[Path, str]:
    """Each existing path's SHA-256 (a folder: its sorted listing), to show that nothing changed."""
    out = {}
    for path in paths:
        if path.is_dir():
            out[path] = ",".join(sorted(p.name for p in path.iterdir()))
        elif path.exists():
            out[path] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def careful(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    """Run `careful ARGS` in this process: (status, stdout, stderr)."""
    capsys.readouterr()
    try:
        status = main([str(a) for a in args])
    except SystemExit as exc:  # argparse
        status = int(exc.code or 0)
    out, err = capsys.readouterr()
    return status, out, err


def careful_process(*args: str | Path, cwd: Path | None = None, timeout: float = 60) -> tuple[int, str, str]:
    """Run `careful ARGS` as its own process (no terminal): (status, stdout, stderr)."""
    done = subprocess.run([sys.executable, "-m", "careful_tui.cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)
    return done.returncode, done.stdout, done.stderr


def assert_refused(status: int, out: str, err: str, *wanted: str) -> str:
    """Exit 2, one line on stderr that says each of `wanted`, no traceback, no raw control character."""
    assert status == 2, (status, out, err)
    line = err.strip()
    assert len(line.splitlines()) == 1, err
    assert line.startswith("careful "), err
    assert "Traceback" not in err
    assert not RAW_CONTROL.search(out + err), repr(out + err)
    for text in wanted:
        assert text in line, (text, line)
    return line


def recording(path: Path, *, world: str = "paper", episodes: int = 3, seed: int = 0) -> Path:
    """An optimal expert's recording of a built-in world."""
    mdp = build_mdp(BUILTIN_WORLDS[world])
    return write_rollouts(path, mdp, rollouts(mdp, optimal_policy(mdp), episodes=episodes, seed=seed),
                          player="expert:optimal", seed=seed)


@contextmanager
def tiny_filesystem(folder: Path, *, size: str = "64k", read_only: bool = False):
    """A tmpfs of `size` mounted at `folder` (a full disk, or a read-only one, that root cannot write either).

    Skips the test where mounting is not allowed.
    """
    folder.mkdir(exist_ok=True)
    options = f"size={size}" + (",ro" if read_only else "")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({done.stderr.decode(errors='replace').strip()})")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def fill(folder: Path) -> None:
    """Fill the file system under `folder` to the last byte."""
    with open(folder / "filler", "wb", buffering=0) as file:
        try:
            while True:
                file.write(b"\0" * 4096)
        except OSError:
            pass
