"""One mapping from hold time to level in both front ends: the terminal's by default, a study
file's when it chooses another, recorded in each header (issue 31: 1,000 ms was level 7 in the
browser and level 4 in the terminal)."""

from __future__ import annotations

from starlette.testclient import TestClient
from web.conftest import STUDY, Api, recorded_lines, web_app, write_web_study

from irl_core.play.hold import HoldProfile
from irl_core.studies.flow import block_options
from irl_core.studies.study import load_study, read_protocol


def test_the_browser_and_the_terminal_give_a_hold_the_same_level_by_default(web_study) -> None:
    terminal = block_options(read_protocol(web_study, "p001"), read_protocol(web_study, "p001").next_block, "p001", None)
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        for ms in (400, 1000, 1600):
            api.hold("left", ms)  # the hall's left wall: the episode goes on
    steps = [line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]
    assert terminal.profile is not None
    assert [s["carefulness"] for s in steps] == [terminal.profile.level_for(ms) for ms in (400, 1000, 1600)] == [1, 5, 9]
    assert HoldProfile(calibrated=True, initial_delay_ms=660.0).level_for(1000) == 5, "calibration leaves the scale"


def test_a_study_file_chooses_the_scale_for_both(tmp_path) -> None:
    path = write_web_study(tmp_path)
    path.write_text(STUDY.format(practice=1, episodes=1) + "tap_ms = 200\nms_per_level = 100\n")
    study = load_study(path)
    protocol = read_protocol(study, "p001")
    terminal = block_options(protocol, protocol.next_block, "p001", None).profile
    assert terminal is not None and (terminal.tap_ms, terminal.ms_per_level) == (200.0, 100.0)
    app, tokens = web_app(study)
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        api.hold("left", 450)
    lines = recorded_lines(study.participant_folder("p001"))
    assert (lines[0]["input"]["tap_ms"], lines[0]["input"]["ms_per_level"]) == (200.0, 100.0)
    assert [line["carefulness"] for line in lines if line["kind"] == "step"] == [4]  # 2 + floor(250 / 100)
