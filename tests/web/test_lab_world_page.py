"""Another lab's task in the browser (docs/worlds.md, "A task from another lab"): a move into a wall in a world
with bump = "drop" is no step, the page says so, and the recording holds only the steps made; the instructions
do not promise that care slips less where the world's split is the same at every level."""

from __future__ import annotations

import pytest
from starlette.testclient import TestClient
from web.conftest import SEAT_KINDS, Api, recorded_lines, seats_of_kind, web_app

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


@pytest.mark.parametrize("seats", SEAT_KINDS)
def test_a_dropped_move_is_shown_and_not_recorded(tmp_path, seats):
    (tmp_path / "hall.toml").write_text(DROP_HALL)
    (tmp_path / "study.toml").write_text(STUDY)
    study = load_study(tmp_path / "study.toml")
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
