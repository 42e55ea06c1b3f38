"""Who may write where, and every bound the server keeps (issue 31), through Starlette's TestClient.

Identity: link participants only through their token; the Prolific route off when there are
links unless asked for; Prolific ids in a namespace of their own, so `PROLIFIC_PID=p001` never
plays as (or ends as) the link participant p001. Bounds: the key budget per participant (a new
page does not refill it) and per address, a bounded number of seats, none holding a file before
the first move, every number checked before use, one JSON error shape, no internals.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from starlette.testclient import TestClient
from web.conftest import Api, recorded_lines, web_app

from careful_tui.web.links import PROLIFIC_PREFIX
from careful_tui.web.seats import Seats
from irl_core.studies.participant_lock import participant_lock
from irl_core.studies.study import read_protocol

PROLIFIC = {"study_id": "S1", "session_id": "X1"}


def prolific(pid: str) -> dict:
    return {"pid": pid, **PROLIFIC}


def assert_refusal(answer, status: int) -> str:
    """The one error shape: JSON {"error": sentence}, with the Content-Security-Policy."""
    assert answer.status_code == status, answer.text
    assert answer.headers["content-type"].startswith("application/json")
    body = answer.json()
    assert set(body) == {"error"} and isinstance(body["error"], str) and body["error"]
    assert "default-src 'none'" in answer.headers["content-security-policy"]
    assert "Traceback" not in answer.text
    return body["error"]


def test_with_links_the_prolific_route_is_off_unless_asked_for(web_study) -> None:
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        page = client.get("/", params={"PROLIFIC_PID": "p001", **{"STUDY_ID": "S1", "SESSION_ID": "X1"}})
        assert page.status_code == 404 and "your link" in page.text
        assert_refusal(client.post("/api/start", json={"prolific": prolific("p001")}), 404)
    assert not web_study.participant_folder("p001").exists()


def test_a_prolific_id_never_names_a_link_participants_folder(web_study) -> None:
    app, tokens = web_app(web_study, completion_code="C0DE-42", prolific=True)
    with TestClient(app) as client:
        linked = Api(client, token=tokens["p001"])
        linked.play_the_study()
        assert linked.view["stage"] == "end" and "complete_url" not in linked.view
        client.post("/api/leave", json={"page": linked.page})
        impostor = Api(client, prolific=prolific("p001"))
        assert impostor.view["stage"] == "instructions" and "complete_url" not in impostor.view
        impostor.key("space")
        impostor.hold("right", 60)
    assert read_protocol(web_study, "p001").finished
    own = web_study.participant_folder(PROLIFIC_PREFIX + "p001")
    assert [line["kind"] for line in recorded_lines(own)][:2] == ["session", "step"]
    assert len([line for line in recorded_lines(web_study.participant_folder("p001")) if line["kind"] == "step"]) == 8


def test_a_prolific_id_like_links_csv_can_save(web_study) -> None:
    app, _ = web_app(web_study, links=0)
    with TestClient(app) as client:
        api = Api(client, prolific=prolific("links.csv"))
        api.key("space")
        assert api.hold("right", 60).status_code == 200
    assert recorded_lines(web_study.participant_folder(PROLIFIC_PREFIX + "links.csv"))


def test_the_key_budget_is_the_participants_not_the_pages(web_study) -> None:
    now = [0.0]
    app, tokens = web_app(web_study, seats=Seats(clock=lambda: now[0]))
    with TestClient(app) as client:
        first = Api(client, token=tokens["p001"])
        first.key("space")
        while first.hold("up", 60).status_code == 200:
            pass
        client.post("/api/leave", json={"page": first.page})
        second = Api(client, token=tokens["p001"])
        assert second.page is not None
        assert_refusal(second.key("space"), 429)


def test_new_seats_from_one_address_are_budgeted(web_study) -> None:
    app, _ = web_app(web_study, links=0, seats=Seats(clock=lambda: 0.0, address_seats=(5, 0.1)))
    with TestClient(app) as client:
        answers = [client.post("/api/start", json={"prolific": prolific(f"inv{k}")}) for k in range(8)]
    assert [a.status_code for a in answers[:5]] == [200] * 5
    assert "Too many" in assert_refusal(answers[5], 429)


def test_seats_are_bounded_and_hold_no_file_before_the_first_move(web_study) -> None:
    app, _ = web_app(web_study, links=0, seats=Seats(limit=3))
    with TestClient(app) as client:
        apis = [Api(client, prolific=prolific(f"s{k}")) for k in range(3)]
        assert all(api.page for api in apis)
        assert not list(web_study.out.rglob("*.lock")) and not list(web_study.out.rglob("*.jsonl"))
        assert "full" in assert_refusal(client.post("/api/start", json={"prolific": prolific("s3")}), 503)
        apis[0].key("space")
        apis[0].hold("right", 60)
        assert list(web_study.out.rglob("*.jsonl"))
        client.post("/api/leave", json={"page": apis[1].page})
        assert Api(client, prolific=prolific("s3")).page is not None


@pytest.mark.parametrize("t", ["1" * 1900, "true", "1e400", "-5", '"12"', "[1]", "null"])
def test_every_number_is_checked_before_use(served_client, t: str) -> None:
    client, api = served_client
    body = '{"page": "%s", "type": "press", "key": "right", "t": %s}' % (api.page, t)
    answer = client.post("/api/key", content=body, headers={"content-type": "application/json"})
    assert_refusal(answer, 400)
    assert api.view["play"]["step"] == 0


@pytest.fixture
def served_client(web_study):
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")
        yield client, api


def test_every_refusal_has_the_one_shape(web_study) -> None:
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        assert_refusal(client.get("/api/key"), 405)
        assert_refusal(client.get("/api/nothing"), 404)
        assert_refusal(client.post("/api/key", content=b"{", headers={"content-type": "application/json"}), 400)
        assert_refusal(client.post("/api/key", content=b"x" * 5000), 413)
        assert_refusal(client.post("/api/key", json={"page": "gone", "type": "space"}), 410)


def test_a_participant_held_elsewhere_is_told_so_without_the_servers_internals(web_study) -> None:
    app, tokens = web_app(web_study)
    with TestClient(app) as client, participant_lock(web_study, "p001", holder="careful study run"):
        Api(client, token=tokens["p001"]).key("space")
        answer = client.post("/api/start", json={"token": tokens["p001"]})
        why = assert_refusal(answer, 409)
    import os
    import socket
    assert str(os.getpid()) not in why and socket.gethostname() not in why and "process" not in why


def test_a_trailing_slash_never_redirects_to_the_host_header(web_study) -> None:
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        answer = client.get(f"/p/{tokens['p001']}/", headers={"host": "evil.example"}, follow_redirects=False)
    assert answer.status_code == 404 and "evil.example" not in answer.headers.get("location", "")


def test_the_folder_of_a_participant_who_never_moved_stays_empty(web_study) -> None:
    app, tokens = web_app(web_study)
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        client.post("/api/leave", json={"page": api.page})
    folder = web_study.participant_folder("p001")
    assert not folder.exists() or not any(Path(folder).iterdir())
