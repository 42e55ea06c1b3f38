"""The play session with no front end, and the terminal's screens on it: whole studies in every
input mode (hold with and without release events, tap, digits), with calibration, a disk that
fills mid-episode and a resume, played once by `session_scenarios` in a process that cannot
import Textual, and once by keys on `StudyScreen`/`PlayScreen` (Pilot). Both write the same
recordings, byte for byte but for the time each file was created."""

from __future__ import annotations

import asyncio
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from play_fixtures import FakeClock
from session_scenarios import MODES, SEED, NoFrontEnd, Script, full_disk_switch, study_script, write_mode_study
from textual.pilot import Pilot

from careful_tui.app import make_study_app
from careful_tui.keys.kitty import KittyParser
from careful_tui.screens.calibration import CalibrationScreen
from careful_tui.screens.play import PlayScreen
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study, read_protocol

HERE = Path(__file__).parent
ROOT = HERE.parents[1]
ARROW_FINAL = {"up": "A", "down": "B", "right": "C", "left": "D"}
CREATED = re.compile(rb'"created": "[^"]*"')


@pytest.fixture(scope="module")
def headless(tmp_path_factory) -> dict[str, list[list[str]]]:
    """Every mode's study played by the session alone, in a process that refuses Textual."""
    out = tmp_path_factory.mktemp("headless")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (ROOT, ROOT / "tests", HERE)))}
    done = subprocess.run([sys.executable, str(HERE / "session_scenarios.py"), str(out)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout)
    assert answer["front_ends_imported"] == []
    return answer["written"]


def test_the_headless_run_refuses_textual() -> None:
    with pytest.raises(ImportError, match="textual.app"):
        NoFrontEnd().find_spec("textual.app", None)
    assert NoFrontEnd().find_spec("numpy", None) is None


@pytest.mark.parametrize("mode", MODES)
def test_a_whole_study_headless_records_every_block_a_full_disk_and_the_resume(headless, mode: str) -> None:
    first, resume = ([read_recording(Path(p)) for p in run] for run in headless[mode])
    # The first run: practice (a level 3 move), then the main block's first episode (level 2)
    # and the second's first step (up) before the disk filled: the step that failed is not kept.
    practice, main = first
    assert [(s.direction, s.carefulness) for s in practice.steps] == [("right", 3)]
    assert [(s.episode, s.direction, s.carefulness) for s in main.steps] == [(0, "right", 2), (1, "up", 1)]
    assert [end.episode for end in main.episode_ends] == [0]
    # The resume plays the interrupted episode again, under the next number, then the rest.
    again, left_practice, left_main = resume
    assert [(s.episode, s.direction, s.carefulness) for s in again.steps] == [(2, "right", 4)]
    assert [s.carefulness for s in left_practice.steps] == [2]
    assert [(s.episode, s.carefulness) for s in left_main.steps] == [(0, 1), (1, 5)]
    assert all(end.outcome == "terminal" for rec in resume for end in rec.episode_ends)
    # Calibration in the hold modes, carried from practice to the main block; a new run starts uncalibrated.
    timed = mode.startswith("hold")
    assert [rec.header.input["calibrated"] for rec in (*first, *resume)] == [timed, timed, False, False, False]
    steps = [s for rec in (*first, *resume) for s in rec.steps]
    if mode == "hold-release":  # a release measures the hold: press at t0, release at t1
        assert all(s.hold_exact for s in steps) and steps[0].hold_ms == pytest.approx(500 + 6 * 33)
    else:
        assert not any(s.hold_exact for s in steps)
    if mode == "hold":  # no release: the last repeat plus half a period
        assert steps[0].hold_ms == pytest.approx(500 + 5 * 33 + 16.5)
    folder = Path(headless[mode][0][0]).parent
    study = load_study(folder.parents[1] / "pilot.toml")
    assert read_protocol(study, "p01").finished


def kitty(key: str, event: int) -> str:
    """An arrow key event in kitty's protocol: 1 press, 2 repeat, 3 release."""
    return f"\x1b[1;1:{event}{ARROW_FINAL[key]}"


def run_on_screens(study_path: Path, script: Script) -> list[list[str]]:
    """Play `script` by keys on the terminal's screens; the files each run wrote, in order."""
    written: list[list[str]] = []
    for run in script:
        clock = FakeClock()
        app = make_study_app(load_study(study_path), "p01", clock=clock, seed=SEED)
        parser = KittyParser()

        async def body(pilot: Pilot, run=run, clock=clock, parser=parser, disk_full=None) -> None:
            for step in run:
                kind = step[0]
                if kind == "disk_full":
                    disk_full[0] = True
                elif kind == "wait":
                    clock.advance(step[1])
                    if isinstance(pilot.app.screen, PlayScreen | CalibrationScreen):
                        pilot.app.screen.tick()
                elif kind in ("space", "c", "enter") or (kind == "key" and step[2] is None):
                    await pilot.press(step[1] if kind == "key" else kind)
                else:
                    code = 3 if kind == "release" else 2 if step[2] else 1
                    for message in parser.feed(kitty(step[1], code)):
                        pilot.app.post_message(message)
                await pilot.pause()

        async def main(body=body, app=app) -> None:
            with full_disk_switch() as disk_full:
                async with app.run_test(size=(100, 35)) as pilot:
                    await pilot.pause()
                    await body(pilot, disk_full=disk_full)

        asyncio.run(main())
        written.append([str(path) for session in app.first_screen.flow.sessions for path in session.recorder.paths])
    return written


@pytest.mark.parametrize("mode", MODES)
def test_the_screens_record_what_the_session_records_headless(headless, tmp_path: Path, mode: str) -> None:
    on_screens = run_on_screens(write_mode_study(tmp_path, mode), study_script(mode))
    alone = headless[mode]
    assert [len(run) for run in on_screens] == [len(run) for run in alone] == [2, 3]
    for screen_path, alone_path in zip(sum(on_screens, []), sum(alone, [])):
        screen_bytes, alone_bytes = (CREATED.sub(b'"created": ""', Path(p).read_bytes()) for p in (screen_path, alone_path))
        assert screen_bytes.splitlines() == alone_bytes.splitlines()
