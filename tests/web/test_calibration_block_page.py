"""A study's motor calibration block in the browser: through the API (TestClient) and in headless Chromium:
the block comes after the instructions, its words are the core's, each hold is a trial line timed exactly,
and practice follows."""

from __future__ import annotations

from pathlib import Path

import pytest
from starlette.testclient import TestClient
from web.conftest import SEAT_KINDS, Api, recorded_lines, seats_of_kind, start_server, web_app, write_web_study
from web.test_page import wait_for

from careful_tui.web.session_adapter import browser_profile
from irl_core.play.motor_block import MOTOR_INTRO, MOTOR_NEXT
from irl_core.studies.study import load_study


def calibrated_study(folder: Path, n: int = 3, *, practice: int = 1):
    path = write_web_study(folder)
    path.write_text(path.read_text().replace("practice_episodes = 1",
                                             f"practice_episodes = {practice}\ncalibration_block = {n}"))
    return load_study(path)


def hold_ms(level: int) -> float:
    """The middle of `level`'s window on the browser's scale (500 ms, then 150 ms a level)."""
    return 250.0 if level == 1 else 500.0 + (level - 1.5) * 150.0


def trials_of(study, participant: str) -> list[dict]:
    folder = study.participant_folder(participant)
    return [line for line in recorded_lines(folder) if line["kind"] == "calibration_trial"] if folder.exists() else []


def test_without_practice_the_page_says_the_game_comes_next(tmp_path: Path) -> None:
    study = calibrated_study(tmp_path, 1, practice=0)
    app, tokens = web_app(study)
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        api.hold("up", hold_ms(api.view["calibration"]["target"]))
        done_line, begin = MOTOR_NEXT["main"]
        assert api.view["calibration"]["instruction"] == done_line and api.view["calibration"]["begin"] == begin
        assert ["space", begin] in api.view["keys"]
        api.key("space")
        assert api.view["stage"] == "play"


@pytest.mark.parametrize("seats", SEAT_KINDS)
def test_the_api_runs_the_block_before_practice(tmp_path: Path, seats: str) -> None:
    study = calibrated_study(tmp_path)
    app, tokens = web_app(study, seats=seats_of_kind(study, seats))
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        assert api.view["stage"] == "calibration"
        calibration = api.view["calibration"]
        assert calibration["intro"] == MOTOR_INTRO and calibration["heading"] == "Calibration · 1 of 3"
        asked = []
        for _ in range(3):
            target = api.view["calibration"]["target"]
            assert f"gauge shows {target}" in api.view["calibration"]["instruction"]
            asked.append(target)
            api.hold("up", hold_ms(target + 1))  # one level long each time
        assert api.view["calibration"]["done"] and api.view["calibration"]["instruction"] == MOTOR_NEXT["practice"][0]
        api.key("space")
        assert api.view["stage"] == "play"
    trials = trials_of(study, "p001")
    assert [(t["target"], t["produced"]) for t in trials] == [(c, c + 1) for c in asked]
    assert all(t["hold_exact"] for t in trials)
    assert [round(t["hold_ms"]) for t in trials] == [round(hold_ms(c + 1)) for c in asked]
    (first,) = sorted(study.participant_folder("p001").glob("*.jsonl"))[:1]
    assert '"front_end":"browser"' in first.read_text().replace(" ", "")


def test_in_chromium_the_gauge_shows_and_the_trials_are_recorded(tmp_path: Path, page) -> None:
    study = calibrated_study(tmp_path, n=2)
    live, server, thread = start_server(study)
    try:
        page.goto(live.link("p001"))
        page.wait_for_selector("#text:not([hidden])")
        assert "a short calibration: 2 holds" in page.inner_text("#text")
        page.keyboard.press(" ")
        page.wait_for_selector("#calib:not([hidden])")
        assert page.inner_text("#calib-heading") == "Calibration · 1 of 2"
        for i in range(2):
            target = int(page.inner_text("#calib-text .target").split("shows ")[1].split(",")[0])
            page.keyboard.down("ArrowUp")
            page.wait_for_timeout(hold_ms(target) * 0.6)
            if i == 0:
                page.screenshot(path=str(tmp_path / "calibration.png"))
                page.screenshot(path="/tmp/calib_bench/calibration.png")
                assert page.inner_text("#calib-now").startswith("Now: level")
            page.wait_for_timeout(hold_ms(target) * 0.4)
            page.keyboard.up("ArrowUp")
            wait_for(lambda n=i + 1: len(trials_of(study, "p001")) >= n, "a trial to be recorded")
        page.wait_for_selector("#calib-text .good")
        assert MOTOR_NEXT["practice"][0] in page.inner_text("#calib-text")
        page.keyboard.press(" ")
        page.wait_for_selector("#play:not([hidden])")
    finally:
        server.should_exit = True
        thread.join(10)
    trials = trials_of(study, "p001")
    assert len(trials) == 2 and all(t["hold_exact"] for t in trials)
    # The first hold is stretched by the screenshot taken during it: its level is its hold's, on the browser's scale.
    profile = browser_profile(14)
    assert all(t["produced"] == profile.level_for(t["hold_ms"]) for t in trials)
    assert (tmp_path / "calibration.png").stat().st_size > 0
