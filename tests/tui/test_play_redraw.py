"""What the play screen shows follows its state: a change redraws once, and a change made while
the window is too small is there when it grows (Pilot, fake clock)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from test_play_app import hold, measure_autorepeat, new_app, run
from test_play_feel import SMALL, calibrated
from textual.pilot import Pilot
from textual.widget import Widget

from careful_tui.widgets import Board, Gauge
from careful_tui.widgets.play_status import GameStatus, HoldInfo
from irl_core.recordings.demonstrations import read_recording


def visible(widget: Widget) -> str:
    """The lines `widget` paints now, as plain text."""
    return "\n".join(widget.render_line(y).text.rstrip() for y in range(widget.size.height))


def test_a_move_redraws_the_status_once_and_a_hold_not_at_all(tmp_path: Path, monkeypatch) -> None:
    # A move changes the cell, the step, the score, the message and the last move at once (and
    # the last one the episode's end and whether it is live): one redraw of the status each time.
    draws: dict[str, list[int]] = {"status": [], "hold": []}
    for name, widget in (("status", GameStatus), ("hold", HoldInfo)):
        monkeypatch.setattr(widget, "render", lambda self, render=widget.render, name=name:
                            (draws[name].append(self.screen.game.t), render(self))[1])
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        mounted = {name: len(calls) for name, calls in draws.items()}
        assert mounted["status"] >= 1 and "step 0/" in visible(app.query_one(GameStatus))
        # Holding right: the gauge and the hold's numbers follow, the status stays as it is.
        await pilot.press("right")
        clock.advance(0.5)
        for _ in range(6):
            await pilot.press("right")
            clock.advance(0.08)
            screen.tick()
            await pilot.pause()
        assert screen.game.t == 0 and app.query_one(Gauge).level == 4
        assert len(draws["status"]) == mounted["status"]
        assert len(draws["hold"]) > mounted["hold"] and "held" in visible(app.query_one(HoldInfo))
        # Let go: the move is made, and the status and the hold's numbers redraw once each.
        clock.advance(1.0)
        screen.tick()
        await pilot.pause()
        assert draws["status"][mounted["status"]:] == [1]
        assert draws["hold"][-1] == 1 and draws["hold"].count(1) == 1
        assert "step 1/" in visible(app.query_one(GameStatus)) and "last move" in visible(app.query_one(HoldInfo))
        # The move that ends the episode (the cliff, below) changes more at once: still one.
        await hold(pilot, clock, "down", 0.0)
        assert not screen.game.live and draws["status"][mounted["status"]:] == [1, 2]
        assert "Press space for the next episode." in visible(app.query_one(GameStatus))

    run(app, body)


def test_what_changes_while_the_window_is_too_small_shows_when_it_grows(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)
    profile = calibrated(0.3, 0.03)

    async def body(pilot: Pilot) -> None:
        screen = app.first_screen
        await hold(pilot, clock, "right", 0.0)
        await hold(pilot, clock, "down", 0.0)  # the cliff: episode 1 ends
        assert not screen.game.live and screen.game.cell == (1, 1)
        await pilot.resize_terminal(*SMALL)
        await pilot.pause()
        assert screen.has_class("-too-small")
        # Hidden, the next episode begins and a calibration is taken.
        await pilot.press("space")
        screen.use_profile(profile)
        await pilot.pause()
        assert screen.game.live and screen.game.cell == (0, 0)
        await pilot.resize_terminal(100, 35)
        await pilot.pause()
        assert not screen.has_class("-too-small")
        status = visible(app.query_one(GameStatus))
        assert "Episode 2   step 0/" in status and "Last episode (1): fell off the cliff" in status
        assert f"Calibrated: a tap is a move after {profile.first_repeat_timeout_ms:.0f} ms." in status
        assert app.query_one(Board).player == (0, 0)
        # The calibration starts a new file at the next move: the title names the folder till then.
        assert screen.recorder.path is None and screen.recording == f"{tmp_path / 'rec'}{os.sep}"
        assert "recording →" in visible(app.query_one("#title"))
        footer = visible(app.query_one("#keys"))
        assert "move · hold longer" in footer and "calibrate" in footer and "next episode" not in footer

    run(app, body)


def test_calibration_tells_the_player_the_tap_wait_it_gives(tmp_path: Path) -> None:
    app, clock = new_app(tmp_path)

    async def body(pilot: Pilot) -> None:
        calibration = await measure_autorepeat(pilot, clock, delay=0.3, repeats=40)
        shown = " ".join(visible(calibration.query_one("#calibration-text")).split())
        wait = app.first_screen.input.header()["tap_wait_ms"]  # still the uncalibrated 700 ms
        assert wait == pytest.approx(700.0)
        measured = calibration.calibrating.calibration.result().first_repeat_timeout_ms
        assert measured < wait and f"A tap (no autorepeat) is a move {measured:.0f} ms after the press." in shown
        await pilot.press("enter")
        await pilot.pause()
        assert f"Calibrated: a tap is a move after {measured:.0f} ms." in visible(app.query_one(GameStatus))
        await hold(pilot, clock, "right", 0.0)

    run(app, body)
    header = read_recording(app.first_screen.recorder.paths[0]).header
    assert header.input["calibrated"] is True
