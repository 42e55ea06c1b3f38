"""`careful play --calibrate` in a real terminal (tmux): a held arrow's autorepeat is measured,
shown, and recorded in the session header."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from test_play_tmux import WORLD, finished_recording
from tmux_terminal import needs_tmux, terminal

pytestmark = needs_tmux

MEASURED = re.compile(r"Autorepeat starts after (\d+) ms and repeats every (\d+) ms\.")


def calibrate(tmp_path: Path):
    """`careful play --calibrate` of the e2e world in a terminal; recordings go to tmp_path/rec."""
    world = tmp_path / "e2e.toml"
    world.write_text(WORLD)
    return terminal(tmp_path, ["play", "--calibrate", "--world", str(world), "--out", str(tmp_path / "rec"),
                               "--player", "e2e", "--seed", "3"])


def test_calibrating_in_a_terminal_measures_the_autorepeat_sent_and_records_it(tmp_path: Path) -> None:
    with calibrate(tmp_path) as session:
        session.wait_for("Hold any arrow key down")
        session.hold("Up", 1.6)  # a press, 500 ms, then a repeat every 33 ms for 1.6 s
        shown = session.wait_for("Measured.")
        session.send("Enter")
        # Until the calibration dialog has gone, a key is its own (the play screen shows behind it): the test
        # once lost its move so on a busy machine.
        session.wait_for(lambda screen: "carefulness" in screen and "Measured." not in screen)
        session.send("Down")
        session.wait_for("step 1/200")
        session.send("q")
        rec = finished_recording(tmp_path / "rec")
    delay_ms, period_ms = map(int, MEASURED.search(" ".join(shown.split())).groups())
    # tmux's keys come as sent give or take the machine's scheduling: the delay is one gap, the
    # period the median of 48.
    assert delay_ms == pytest.approx(500, abs=100) and period_ms == pytest.approx(33, abs=8)
    header = rec.header.input
    assert header["calibrated"] and header["mode"] == "hold"
    assert round(header["initial_delay_ms"]) == delay_ms and round(header["repeat_period_ms"]) == period_ms
