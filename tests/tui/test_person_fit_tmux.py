"""From a person's play to an answer: play in a real terminal (tmux), then `careful fit` the file.

The player walks mostly the optimal way but picks a different carefulness at each move, as people
do; moves slip. The default fit (method auto) must answer with an interval for every unknown.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

from tmux_terminal import TIMEOUT_S, needs_tmux, terminal

from irl_core.recordings.demonstrations import read_recording
from irl_core.worlds.world import load_world

pytestmark = needs_tmux

WORLD = """\
name = "walk"
layout = \"\"\"
......
......
......
.CCCCG
\"\"\"
levels = 14
start = [2, 0]
[rewards]
C = -1000.0
G = 100.0
"""
LEVELS = "35847296"  # a person's carefulness: noisy, typed before each move (digits input)
EPISODES = 4


def line_at(path: Path, index: int) -> dict:
    return json.loads(path.read_text(encoding="utf-8").splitlines()[index])


def session_file(out: Path, timeout: float = TIMEOUT_S) -> Path:
    """The one recording in `out` (play creates it at the first move)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        files = list(out.glob("*.jsonl")) if out.exists() else []
        if files:
            (path,) = files
            return path
        time.sleep(0.03)
    raise AssertionError(f"no recording appeared in {out}")


def wait_for_lines(path: Path, count: int, timeout: float = TIMEOUT_S) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if path.exists() and len(path.read_text(encoding="utf-8").splitlines()) >= count:
            return
        time.sleep(0.03)
    raise AssertionError(f"{path} never reached {count} lines")


def test_a_person_like_recording_from_play_fits_with_an_interval_for_every_unknown(tmp_path: Path) -> None:
    world = tmp_path / "walk.toml"
    world.write_text(WORLD)
    walk = load_world(world)
    out = tmp_path / "rec"
    with terminal(tmp_path, ["play", "--world", str(world), "--out", str(out), "--input", "digits",
                             "--player", "person", "--seed", "7"]) as session:
        session.wait_for("Episode 1")
        cell, lines, moves, ended = (2, 0), 1, 0, 0
        while ended < EPISODES and moves < 80:
            row, col = cell
            arrow = "Down" if col == 5 or row < 2 else "Right"
            session.send(LEVELS[moves % len(LEVELS)])
            session.send(arrow)
            moves += 1
            lines += 1
            recording = session_file(out)
            wait_for_lines(recording, lines)
            step = line_at(recording, lines - 1)
            assert step["kind"] == "step" and step["carefulness"] == int(LEVELS[(moves - 1) % len(LEVELS)])
            cell = tuple(step["next_state"])
            # The step says whether the episode ends (it entered a terminal cell), so the episode_end line is
            # waited for, not guessed from a fixed wait.
            if walk.symbol(cell) in walk.terminal:
                lines += 1  # the episode_end line
                wait_for_lines(recording, lines)
                ended += 1
                session.wait_for("Press space")
                session.send("Space")
                cell = (2, 0)
        session.send("q")
        session.wait_for("recorded to")
    rec = read_recording(recording)
    assert len(rec.episodes) >= EPISODES
    assert len({step.carefulness for step in rec.steps}) > 3  # noisy levels, as a person plays

    fitted = tmp_path / "fit.json"
    run = subprocess.run([sys.executable, "-m", "careful_tui.cli", "fit", str(recording), "--no-view",
                          "--intervals", "--resamples", "40", "--json", str(fitted)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    result = json.loads(fitted.read_text())
    assert result["method"] == "maxent" and result["interval_kind"] == "confidence"
    unknown = [(r, c) for r, row in enumerate(result["unknown"]) for c, flag in enumerate(row) if flag]
    assert unknown and all(result["interval"][r][c] is not None for r, c in unknown)
    assert "confidence" in run.stdout and "chosen by auto" in " ".join(run.stdout.split())


