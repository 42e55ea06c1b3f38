"""A time world in the browser (docs/timing.md): no gauge, the hold from keydown to keyup recorded exactly with
its duration bin and no carefulness, and the held time shown only when the world says so."""

from __future__ import annotations

import time

import pytest
from starlette.testclient import TestClient
from web.conftest import SEAT_KINDS, Api, recorded_lines, seats_of_kind, start_server, web_app

from irl_core.studies.study import load_study
from irl_core.worlds.world import BUILTIN_WORLDS

TIMED_HALL = """\
name = "timed hall"
layout = "....G"
care = "time"
show_hold = {show}
start = [0, 0]
terminal = ["G"]
rewards = {{ G = 100.0 }}
"""
STUDY = """\
name = "timing pilot"
worlds = ["hall.toml"]
practice_episodes = 0
episodes = 1
out = "data"
"""


def timed_study(folder, *, show: bool):
    (folder / "hall.toml").write_text(TIMED_HALL.format(show=str(show).lower()))
    (folder / "study.toml").write_text(STUDY)
    return load_study(folder / "study.toml")


def steps(study, participant: str) -> list[dict]:
    folder = study.participant_folder(participant)
    return [line for line in recorded_lines(folder) if line["kind"] == "step"] if folder.exists() else []


@pytest.mark.parametrize("seats", SEAT_KINDS)
def test_a_time_worlds_view_has_no_levels_and_its_steps_no_carefulness(tmp_path, seats):
    study = timed_study(tmp_path, show=False)
    app, tokens = web_app(study, seats=seats_of_kind(study, seats))
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        words = " ".join(paragraph["text"] for paragraph in api.view["paragraphs"])
        assert "the longer you hold an arrow key" in words.lower() and "level" not in words and "gauge" not in words
        api.key("space")
        play = api.view["play"]
        assert play["care"] == "time" and play["levels"] == [] and play["show_hold"] is False
        for ms in (80, 2500, 300, 40):
            api.hold("right", ms)
    world = study.worlds[0]
    recorded = steps(study, "p001")
    assert [(s["carefulness"], s["hold_ms"], s["hold_exact"], s["bin"]) for s in recorded] == [
        (None, ms, True, int(world.bin_of(ms))) for ms in (80, 2500, 300, 40)]
    assert recorded[1]["reward"] == pytest.approx(-world.cost_per_second * 2.5)


@pytest.mark.parametrize("show", [False, True])
def test_the_page_shows_no_gauge_and_the_held_time_only_when_asked(page, tmp_path, show):
    study = timed_study(tmp_path, show=show)
    live, server, thread = start_server(study)
    try:
        page.goto(live.link("p001"))
        page.wait_for_selector("#text:not([hidden])")
        page.keyboard.press(" ")
        page.wait_for_selector("#play:not([hidden])")
        assert not page.locator("#gauge").is_visible() and not page.locator("#gauge-caption").is_visible()
        page.keyboard.down("ArrowRight")
        page.wait_for_timeout(400)
        during = page.inner_text("#hold-info")
        page.screenshot(path=str(tmp_path / f"holding-{show}.png"))
        page.keyboard.up("ArrowRight")
        deadline = time.monotonic() + 10
        while not steps(study, "p001") and time.monotonic() < deadline:
            time.sleep(0.02)
        (step,) = steps(study, "p001")
        assert step["carefulness"] is None and step["hold_exact"] and 380 <= step["hold_ms"] <= 2000
        assert ("held" in during) == show and "level" not in during
        page.locator("#hold-info", has_text="last move").wait_for()
        after = page.inner_text("#hold-info")
        assert ("held" in after) == show and "level" not in after
    finally:
        server.should_exit = True
        thread.join(10)


def test_the_built_in_time_worlds_can_be_a_studys_worlds(tmp_path):
    (tmp_path / "study.toml").write_text(STUDY.replace('"hall.toml"', '"mud-time", "paper-time"'))
    study = load_study(tmp_path / "study.toml")
    assert [w.name for w in study.worlds] == ["mud-time", "paper-time"]
    assert study.worlds[0] == BUILTIN_WORLDS["mud-time"]
