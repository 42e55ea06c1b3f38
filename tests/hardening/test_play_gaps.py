"""Holds through a real terminal (tmux) with delivery gaps of 100-400 ms make one move each.

tmux, an SSH hop or a loaded machine can hold a key's autorepeats back; the silence ends the hold
and the repeats that follow are its tail, never moves (`irl_core.play.hold.HoldDetector`). Run
idle and with every core busy.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from pathlib import Path

import pytest
from test_play_abuse import assert_consistent, play_args, quit_game, settle, the_recording
from tmux_terminal import Terminal, needs_tmux, terminal

GAPS_S = (0.1, 0.2, 0.3, 0.4)
KEYS = ("Right", "Left", "Right", "Left")


@contextmanager
def busy_cores() -> Iterator[None]:
    """A spinning process per core, for the duration (stopped by their own ids)."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(os.cpu_count() or 2)]
    try:
        yield
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def hold_with_gap(term: Terminal, key: str, gap_s: float) -> None:
    """Press, the keyboard's 500 ms delay, repeats for 400 ms, a delivery gap, repeats for 500 ms."""
    term.hold(key, 0.4)
    time.sleep(gap_s)
    term.repeat(key, 0.5)


@needs_tmux
@pytest.mark.parametrize("load", ["idle", "busy"])
def test_a_delivery_gap_never_splits_a_hold_into_moves(tmp_path: Path, load: str) -> None:
    out = tmp_path / "rec"
    with terminal(tmp_path, play_args(tmp_path)) as term:
        term.wait_for("carefulness")
        shown = 0
        with busy_cores() if load == "busy" else nullcontext():
            for key, gap in zip(KEYS, GAPS_S):
                hold_with_gap(term, key, gap)
                shown = settle(term, shown + 1)
        quit_game(term)
    rec = the_recording(out)
    assert_consistent(rec)
    assert [s.direction for s in rec.steps] == [key.lower() for key in KEYS], \
        [(s.direction, s.carefulness, s.hold_ms) for s in rec.steps]
    assert all(s.carefulness >= 2 for s in rec.steps), "each hold keeps the level held before its gap"

