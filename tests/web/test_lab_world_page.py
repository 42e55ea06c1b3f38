"""Another lab's task in the browser (docs/worlds.md, "A task from another lab"): a move into a wall in a world
with bump = "drop" is no step, the page says so, and the recording holds only the steps made; the instructions
do not promise that care slips less where the world's split is the same at every level."""

from __future__ import annotations

import pytest
from starlette.testclient import TestClient
from web.conftest import SEAT_KINDS, Api, recorded_lines, seats_of_kind, start_server, web_app

from irl_core.studies.study import load_study

DROP_HALL = """\
name = "drop hall"
layout = "....G"
levels = 2
slip = {intended = 1.0, others = [0.0, 0.0, 0.0]}
bump = "drop"
start = [0, 0]
terminal = ["G"]
rewards = { G = 100.0 }
"""
STUDY = """\
name = "drop pilot"
worlds = ["hall.toml"]
practice_episodes = 0
episodes = 1
out = "data"
"""


def drop_study(folder):
    (folder / "hall.toml").write_text(DROP_HALL)
    (folder / "study.toml").write_text(STUDY)
    return load_study(folder / "study.toml")


@pytest.mark.parametrize("seats", SEAT_KINDS)
def test_a_dropped_move_is_shown_and_not_recorded(tmp_path, seats):
    study = drop_study(tmp_path)
    app, tokens = web_app(study, seats=seats_of_kind(study, seats))
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        words = " ".join(paragraph["text"] for paragraph in api.view["paragraphs"])
        assert "A careful move costs more points and slips no less" in words  # the split is the same at each level
        api.key("space")
        for key in ("up", "left", "down"):
            assert api.hold(key, 60).status_code == 200
            assert api.view["play"]["message"] == f"{key}: blocked, no move made" and api.view["play"]["step"] == 0
        api.walk_to_goal()
    steps = [line for line in recorded_lines(study.participant_folder("p001")) if line["kind"] == "step"]
    assert [(s["state"], s["next_state"]) for s in steps] == [([0, c], [0, c + 1]) for c in range(4)]


def test_chromium_shows_a_blocked_move_and_then_the_step(page, tmp_path):
    study = drop_study(tmp_path)
    live, server, thread = start_server(study)
    try:
        page.goto(live.link("p001"))
        page.wait_for_selector("#text:not([hidden])")
        page.keyboard.press(" ")
        page.wait_for_selector("#play:not([hidden])")
        page.keyboard.press("ArrowUp")
        page.locator("#status", has_text="up: blocked, no move made").wait_for()
        assert "step 0/" in page.inner_text("#status")
        page.keyboard.press("ArrowRight")
        page.locator("#status", has_text="step 1/").wait_for()
        assert "blocked" not in page.inner_text("#status")
    finally:
        server.should_exit = True
        thread.join(10)
    steps = [line for line in recorded_lines(study.participant_folder("p001")) if line["kind"] == "step"]
    assert [(s["state"], s["next_state"]) for s in steps] == [([0, 0], [0, 1])]
