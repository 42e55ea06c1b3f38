"""Requests a stranger can send `careful serve` (issue 45): each is answered 4xx in the one error shape, and
the experimenter's console shows no traceback."""

from __future__ import annotations

import json

import pytest
from starlette.testclient import TestClient
from web.conftest import SEAT_KINDS, Api, seats_of_kind, web_app, write_web_study

from irl_core.studies.study import load_study

ODD_PAGES = ["p001/é", "p001/\u202e", "p001/" + "\ud800", "p001/x\x00", "é/abc", "p001/" + "a" * 24 + "é"]


@pytest.mark.parametrize("kind", SEAT_KINDS)
def test_a_page_id_with_characters_no_page_id_has_is_a_4xx_never_a_500(tmp_path, kind):
    """`{"page": "p001/é"}` once reached `hmac.compare_digest` on text: a 500 and a traceback."""
    study = load_study(write_web_study(tmp_path))
    app, tokens = web_app(study, seats=seats_of_kind(study, kind))
    with TestClient(app, raise_server_exceptions=False) as client:
        assert Api(client, token=tokens["p001"]).page is not None  # p001 holds a seat to compare against
        for page in ODD_PAGES:
            for path, body in (("/api/key", {"page": page, "type": "space"}), ("/api/alive", {"page": page}),
                               ("/api/leave", {"page": page})):
                # As JSON text with \u escapes: a lone surrogate travels as the page would send it.
                answer = client.post(path, content=json.dumps(body), headers={"content-type": "application/json"})
                assert answer.status_code in (204, 410), (path, page, answer.status_code, answer.text)


def call_with_body_cut_off(app, path: str) -> list[dict]:
    """POST `path` to the ASGI app as a client that sends part of its body and disconnects; the messages sent
    back. Raises what the app raises (what uvicorn would print as a traceback on the console)."""
    import anyio

    incoming = [{"type": "http.request", "body": b'{"page": "p0', "more_body": True}, {"type": "http.disconnect"}]
    sent: list[dict] = []

    async def receive() -> dict:
        return incoming.pop(0) if incoming else {"type": "http.disconnect"}

    async def send(message: dict) -> None:
        sent.append(message)

    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST", "scheme": "http",
             "path": path, "raw_path": path.encode(), "query_string": b"", "root_path": "",
             "headers": [(b"content-type", b"application/json"), (b"content-length", b"200")],
             "client": ("127.0.0.1", 5000), "server": ("127.0.0.1", 8000), "state": {"served": app.state.served}}
    anyio.run(app, scope, receive, send)
    return sent


@pytest.mark.parametrize("path", ["/api/start", "/api/key", "/api/alive", "/api/leave"])
def test_a_client_gone_mid_body_is_no_traceback(tmp_path, path):
    study = load_study(write_web_study(tmp_path))
    app, _ = web_app(study)
    sent = call_with_body_cut_off(app, path)  # raised ClientDisconnect, which uvicorn printed with its traceback
    assert sent[0]["type"] == "http.response.start" and 400 <= sent[0]["status"] < 500
