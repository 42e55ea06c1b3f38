"""The server's requests, through Starlette's TestClient: links and Prolific ids, bounded bodies,
the Content-Security-Policy, one page per participant, the key budget, texts as text, the files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from starlette.testclient import TestClient
from web.conftest import SEAT_KINDS, Api, recorded_lines, seats_of_kind, web_app

from careful_tui.web.links import LINKS_FILE, add_links, read_links
from careful_tui.web.seats import SILENT_S, Seats
from careful_tui.web.server import MAX_BODY
from careful_tui.web.session_adapter import browser_profile
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import read_protocol


@pytest.fixture(params=SEAT_KINDS)
def served(web_study, request):
    """The app with one process's seats, and with the seats every worker of `--workers N` shares (in files)."""
    app, tokens = web_app(web_study, completion_code="C0DE-42", prolific=True, seats=seats_of_kind(web_study, request.param))
    with TestClient(app) as client:
        yield client, tokens


def files_under(folder: Path) -> set[str]:
    return {str(path.relative_to(folder)) for path in folder.rglob("*")}


def test_every_answer_carries_the_content_security_policy(served):
    client, tokens = served
    for answer in (client.get(f"/p/{tokens['p001']}"), client.get("/static/page.js"), client.get("/p/nope-nope-nope-nope"),
                   client.post("/api/start", json={"token": tokens["p001"]})):
        policy = answer.headers["content-security-policy"]
        assert "script-src 'self'" in policy and "default-src 'none'" in policy
        assert "unsafe-inline" not in policy
        assert answer.headers["x-content-type-options"] == "nosniff"


def test_a_link_opens_the_page_and_an_unknown_or_guessed_token_gets_404(served):
    client, tokens = served
    assert client.get(f"/p/{tokens['p001']}").status_code == 200
    guessed = tokens["p001"][:-1] + ("A" if tokens["p001"][-1] != "A" else "B")
    for token in (guessed, "p001", "../../etc/passwd"):
        assert client.get(f"/p/{token}").status_code == 404
        assert client.post("/api/start", json={"token": token}).status_code == 404
    assert "not valid" in client.get(f"/p/{guessed}").text


@pytest.mark.parametrize("pid", ["a/b", "..", "../escape", "p\x07x", "x" * 200, ""])
def test_a_prolific_id_that_cannot_name_a_folder_is_refused_with_a_page_that_says_why(served, web_study, pid):
    client, _ = served
    before = files_under(web_study.path.parent)
    answer = client.get("/", params={"PROLIFIC_PID": pid, "STUDY_ID": "s1", "SESSION_ID": "x1"})
    assert answer.status_code == 400
    assert "cannot name a folder" in answer.text and "<script" not in answer.text
    started = client.post("/api/start", json={"prolific": {"pid": pid, "study_id": "s1", "session_id": "x1"}})
    assert started.status_code == 400 and "cannot name a folder" in started.json()["error"]
    assert files_under(web_study.path.parent) == before


def test_a_prolific_participant_is_recorded_with_the_studys_and_sessions_ids(served, web_study):
    client, _ = served
    ids = {"pid": "5f0c0ffee0123456789abcde", "study_id": "65aa11", "session_id": "sess-77"}
    assert client.get("/", params={"PROLIFIC_PID": ids["pid"], "STUDY_ID": "65aa11", "SESSION_ID": "sess-77"}).status_code == 200
    api = Api(client, prolific=ids, user_agent="Mozilla/5.0 (test)")
    participant = "prolific-" + ids["pid"]  # Prolific's ids in their own namespace
    assert api.view["participant"] == participant
    api.key("space")
    api.walk_to_goal()
    header = recorded_lines(web_study.participant_folder(participant))[0]
    assert header["prolific"] == {"study_id": "65aa11", "session_id": "sess-77"}
    assert header["input"]["mode"] == "hold" and header["input"]["front_end"] == "browser"
    assert header["input"]["user_agent"] == "Mozilla/5.0 (test)"
    assert header["player"] == participant and header["study"]["phase"] == "practice"


def test_a_body_over_the_limit_gets_413_and_plays_nothing(served, web_study):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    big = json.dumps({"page": api.page, "type": "press", "key": "right", "t": 1.0, "pad": "x" * MAX_BODY})
    assert client.post("/api/key", content=big, headers={"content-type": "application/json"}).status_code == 413

    def chunks():  # no content-length: the server stops reading at the limit
        yield big.encode()

    assert client.post("/api/key", content=chunks()).status_code == 413
    assert client.post("/api/start", content=b"[" * (MAX_BODY + 1)).status_code == 413
    assert client.post("/api/key", content=b"[" * 1500).status_code == 400
    assert api.view["play"]["step"] == 0


def test_a_second_page_for_a_participant_is_refused_while_the_first_plays(served, web_study):
    client, tokens = served
    first = Api(client, token=tokens["p001"])
    first.key("space")
    first.hold("right", 400)
    second = Api(client, token=tokens["p001"])
    assert second.answer.status_code == 409 and "another tab" in second.answer.json()["error"]
    assert second.key("press", key="right", t=1.0).status_code == 410
    first.hold("right", 400)
    steps = [line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]
    assert [step["t"] for step in steps] == [0, 1]
    assert len(list(web_study.participant_folder("p001").glob("*.jsonl"))) == 1
    assert Api(client, token=tokens["p002"]).answer.status_code == 200  # another participant plays at once


def test_after_the_first_page_leaves_a_new_page_resumes_where_the_files_say(served, web_study):
    client, tokens = served
    first = Api(client, token=tokens["p001"])
    first.key("space")
    first.walk_to_goal()
    first.key("space")  # practice over
    first.key("space")  # the main block begins
    first.hold("right", 100)
    assert client.post("/api/leave", json={"page": first.page}).status_code == 204
    again = Api(client, token=tokens["p001"])
    assert again.answer.status_code == 200
    assert "Welcome back: 1 of 2 episodes are done" in again.view["paragraphs"][1]["text"]
    again.key("space")
    assert again.view["play"]["episode"] == "Episode 1 of 1" and again.view["play"]["step"] == 0
    again.walk_to_goal()
    again.key("space")
    assert again.view["stage"] == "end"
    lines = recorded_lines(web_study.participant_folder("p001"))
    ends = [(line["episode"], line["outcome"]) for line in lines if line["kind"] == "episode_end"]
    assert sorted(ends) == [(0, "quit"), (0, "terminal"), (1, "terminal")]
    assert read_protocol(web_study, "p001").finished


def test_a_flood_of_keys_is_rate_limited_and_not_recorded(web_study):
    now = [0.0]  # the budget refills by this clock: none during the flood, a second's worth after it
    app, tokens = web_app(web_study, seats=Seats(clock=lambda: now[0]))
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        answers = [api.hold("up", 60).status_code for _ in range(100)]
        assert answers[:11] == [200] * 11 and set(answers[12:]) == {429}
        steps = [line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]
        assert len(steps) == 11
        assert "Too many keys" in client.post("/api/key", json={"page": api.page, "type": "space"}).json()["error"]
        now[0] += 1.0
        assert api.hold("up", 60).status_code == 200
    assert len([line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]) == 12


def test_holds_are_recorded_exact_at_the_levels_the_browser_timing_gives(served, web_study):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    for ms in (50, 499.9, 500, 650, 800, 2500):
        api.hold("up", ms)
    steps = [line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]
    profile = browser_profile(14)
    assert [step["hold_ms"] for step in steps] == [50, 499.9, 500, 650, 800, 2500]
    assert [step["carefulness"] for step in steps] == [1, 1, 2, 3, 4, 14]  # the terminal's scale
    assert all(step["hold_exact"] for step in steps)
    assert [step["carefulness"] for step in steps] == [profile.level_for(step["hold_ms"]) for step in steps]


def test_a_hold_cancelled_by_lost_focus_moves_nothing(served, web_study):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    api.key("press", key="right", t=10.0)
    api.key("cancel")
    api.key("release", key="right", t=500.0)
    assert api.view["play"]["step"] == 0 and "cancelled" in api.view["play"]["message"]
    assert not web_study.participant_folder("p001").exists()


def test_the_page_cannot_choose_an_outcome_a_time_or_a_key_that_is_not_one(served, web_study):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    for fields in ({"key": "teleport", "t": 1.0}, {"key": "right", "t": "soon"}, {"key": "right", "t": -5},
                   {"key": ["right"], "t": 1.0}):
        assert api.key("press", **fields).status_code == 400
    assert api.key("move", key="right", next_state=[0, 4]).status_code == 400
    assert client.post("/api/key", content=b'{"page": "%s", "type": "press", "key": "right", "t": NaN}' % api.page.encode()).status_code == 400
    assert api.view["play"]["step"] == 0


def test_study_and_world_texts_travel_as_text_and_the_page_never_parses_html(served):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    texts = [p["text"] for p in api.view["paragraphs"]]
    assert "web <b>pilot</b>" in texts and any("<img src=x onerror=alert(1)>" in text for text in texts)
    api.key("space")
    assert "<script>" in api.view["play"]["heading"] or "<i>of</i>" in api.view["play"]["heading"]
    script = client.get("/static/page.js").text
    for parser in ("innerHTML", "outerHTML", "insertAdjacentHTML", "document.write", "eval(", "new Function"):
        assert parser not in script


def test_the_completion_address_comes_only_at_the_end_for_a_prolific_participant(served, web_study):
    client, tokens = served
    api = Api(client, prolific={"pid": "PP1", "study_id": "S", "session_id": "X"})
    api.key("space")
    api.walk_to_goal()
    assert "complete_url" not in api.view
    api.key("space")
    api.key("space")
    api.walk_to_goal()
    assert "complete_url" not in api.view
    api.key("space")
    assert api.view["stage"] == "end"
    assert api.view["complete_url"] == "https://app.prolific.com/submissions/complete?cc=C0DE-42"
    assert read_protocol(web_study, "prolific-PP1").finished
    linked = Api(client, token=tokens["p002"])  # a link participant is not sent to Prolific
    linked.play_the_study()
    assert linked.view["stage"] == "end" and "complete_url" not in linked.view


def test_links_are_appended_never_rewritten_and_readable_by_the_owner_only(web_study):
    first = add_links(web_study, 2)
    path = web_study.out / LINKS_FILE
    before = path.read_text()
    web_study.participant_folder("p003").mkdir(parents=True)  # an id someone already plays as is skipped
    second = add_links(web_study, 2)
    assert path.read_text().startswith(before)
    assert [p for p, _ in first] == ["p001", "p002"] and [p for p, _ in second] == ["p004", "p005"]
    assert len(set(read_links(web_study))) == 4
    assert all(len(token) >= 20 for token in read_links(web_study))
    assert path.stat().st_mode & 0o077 == 0


def test_q_leaves_keeping_what_was_played(served, web_study):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    api.hold("right", 200)
    assert api.key("quit").status_code == 200
    assert api.view["stage"] == "left"
    ends = [line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "episode_end"]
    assert [end["outcome"] for end in ends] == ["quit"]
    assert api.key("space").status_code == 410


def test_a_browser_recording_reads_like_a_terminal_one(served, web_study):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    api.walk_to_goal(ms=400)
    path = next(web_study.participant_folder("p001").glob("*.jsonl"))
    recording = read_recording(path)
    assert recording.header.input["front_end"] == "browser"
    assert recording.steps.column("hold_exact").all()
    assert recording.header.study.participant == "p001"


def test_a_page_silent_for_too_long_gives_its_place_to_the_next_one(web_study):
    now = [0.0]
    app, tokens = web_app(web_study, seats=Seats(clock=lambda: now[0]))
    with TestClient(app) as client:
        first = Api(client, token=tokens["p001"])
        first.key("space")
        first.hold("right", 100)
        now[0] += SILENT_S - 1
        assert Api(client, token=tokens["p001"]).answer.status_code == 409
        assert client.post("/api/alive", json={"page": first.page}).status_code == 204  # heard from: it stays
        now[0] += SILENT_S - 1
        assert Api(client, token=tokens["p001"]).answer.status_code == 409
        now[0] += SILENT_S
        second = Api(client, token=tokens["p001"])
        assert second.answer.status_code == 200
        assert first.key("press", key="right", t=1.0).status_code == 410
    ends = [line["outcome"] for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "episode_end"]
    assert ends == ["quit"]


def test_a_recording_that_cannot_be_written_stops_the_participant_with_a_sentence(served, web_study, monkeypatch):
    client, tokens = served
    api = Api(client, token=tokens["p001"])
    api.key("space")
    api.hold("right", 100)

    def full(self, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("irl_core.recordings.writer.RecordingWriter._write_bytes", full)
    answer = api.hold("right", 100)
    assert answer.status_code == 503 and "cannot save your moves" in answer.json()["error"]
    assert api.key("press", key="right", t=1.0).status_code == 410
    monkeypatch.undo()
    steps = [line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]
    assert len(steps) == 1


def test_a_participant_held_by_another_session_is_refused_and_a_page_holds_the_lock_from_its_first_key(
        served, web_study):
    from irl_core.errors import ParticipantBusy
    from irl_core.studies.participant_lock import participant_lock

    client, tokens = served
    with participant_lock(web_study, "p001", holder="careful study run"):
        refused = Api(client, token=tokens["p001"])
        assert refused.answer.status_code == 409 and "open for you elsewhere" in refused.answer.json()["error"]
    page = Api(client, token=tokens["p001"])
    assert page.answer.status_code == 200
    with participant_lock(web_study, "p001", holder="careful study run"):
        pass  # a page that has not played holds no file
    page.key("space")
    with pytest.raises(ParticipantBusy, match="careful serve"):
        with participant_lock(web_study, "p001", holder="careful study run"):
            pass
    client.post("/api/leave", json={"page": page.page})
    with participant_lock(web_study, "p001", holder="careful study run"):
        pass
