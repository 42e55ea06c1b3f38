"""`careful study run` with a motor calibration block, driven by keys (Pilot, digits input): the block
comes after the instructions and before practice, its words are the core's, its trials land in the
participant's first file, and q mid-block keeps what was done."""

from __future__ import annotations

import io
import json
from pathlib import Path

from rich.console import Console
from study.study_run_files import write_study
from test_study_run import new_app, run
from textual.widgets import Static

from careful_tui.screens.motor import MotorScreen
from careful_tui.screens.play import PlayScreen
from careful_tui.widgets import Gauge, KeyBar
from irl_core.play.motor_block import MOTOR_NEXT
from irl_core.studies.study import load_study, read_protocol


def motor_text(app) -> str:
    console = Console(width=80, file=io.StringIO(), record=True)
    console.print(app.screen.query_one("#motor-text", Static).content)
    return console.export_text()


def gauge_marks(app) -> list[int]:
    """The levels whose number the calibration gauge draws reversed (the target's mark), read from its rows."""
    gauge = app.screen.query_one("#motor-gauge", Gauge)
    marked = []
    for y in range(gauge.levels):
        number = gauge.render_line(y)._segments[0]
        if number.style is not None and number.style.reverse:
            marked.append(int(number.text))
    return marked


def target_of(app) -> int:
    assert isinstance(app.screen, MotorScreen), type(app.screen)
    view = app.screen.block.view()
    assert view.target is not None
    return view.target


def test_the_block_runs_between_instructions_and_practice(tmp_path: Path) -> None:
    path = write_study(tmp_path, calibration=3)
    app = new_app(path)

    async def body(pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        made = []
        for i in range(3):
            target = target_of(pilot.app)
            assert gauge_marks(pilot.app) == [target]  # the level asked for is marked on the gauge, as in the browser
            assert f"gauge shows {target}" not in motor_text(pilot.app)  # digits input: no gauge words
            assert f"level {target} move" in motor_text(pilot.app) and f"{i + 1} of 3" in motor_text(pilot.app)
            produced = max(1, target - 1)
            await pilot.press(str(produced), "up")
            await pilot.pause()
            made.append((target, produced))
        assert MOTOR_NEXT["practice"][0] in motor_text(pilot.app)
        await pilot.press("space")
        await pilot.pause()
        assert isinstance(pilot.app.screen, PlayScreen)
        pilot.app.made = made

    run(app, body)
    (first,) = sorted((tmp_path / "data" / "p01").glob("*.jsonl"))
    lines = [json.loads(line) for line in first.read_text().splitlines()]
    assert [(t["target"], t["produced"]) for t in lines[1:]] == app.made
    assert all(t["kind"] == "calibration_trial" for t in lines[1:])


def test_without_practice_the_block_says_the_game_comes_next(tmp_path: Path) -> None:
    """A study with no practice: the block's last line and its go-on key name the game, not practice."""
    path = write_study(tmp_path, practice=0, calibration=1)
    app = new_app(path)

    async def body(pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        await pilot.press(str(target_of(pilot.app)), "up")
        await pilot.pause()
        done_line, begin = MOTOR_NEXT["main"]
        assert done_line in motor_text(pilot.app) and f"Press space to {begin}." in motor_text(pilot.app)
        assert "ractice" not in motor_text(pilot.app)
        assert ("space", begin) in pilot.app.screen.query_one(KeyBar).keys
        await pilot.press("space")
        await pilot.pause()
        assert isinstance(pilot.app.screen, PlayScreen)

    run(app, body)


def test_q_mid_block_keeps_the_trials_and_the_next_run_asks_the_rest(tmp_path: Path) -> None:
    path = write_study(tmp_path, calibration=3)

    async def one_then_quit(pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        await pilot.press("2", "up", "q")
        await pilot.pause()

    run(new_app(path), one_then_quit)
    assert read_protocol(load_study(path), "p01").calibration_trials == 1

    async def the_rest(pilot) -> None:
        await pilot.press("space")
        await pilot.pause()
        assert "2 of 3" in motor_text(pilot.app)

    run(new_app(path), the_rest)
