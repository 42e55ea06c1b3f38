"""`careful serve` as a process and a socket: its stops, its bad options, its connections.

SIGTERM ends with the "stopped" line (it exited without it); a second Ctrl+C while stopping prints
no traceback (it printed four); `--host ''` and `--links 1000000000` are one line, exit 2 (one
listened on every interface, the other ran 80 s into MemoryError); a connection that never
finishes its request's head is dropped (400 such stayed open); uvicorn's own 400 carries the
Content-Security-Policy and the one error shape.
"""

from __future__ import annotations

import json
import signal
import socket
import threading
import time

import pytest
from test_serve_command import Served
from web.conftest import web_app, write_web_study

from careful_tui.cli import main
from careful_tui.commands.serve import bind, make_server


@pytest.mark.parametrize("signals", [[signal.SIGTERM], [signal.SIGINT, signal.SIGINT]], ids=["SIGTERM", "Ctrl+C twice"])
def test_a_stop_by_signal_says_so_and_prints_no_traceback(tmp_path, signals) -> None:
    served = Served(write_web_study(tmp_path), "--links", "1")
    try:
        for sig in signals:
            served.process.send_signal(sig)
            time.sleep(0.05)
        out, _ = served.process.communicate(timeout=20)
    finally:
        served.stop()
    assert served.process.returncode == 0, out
    assert "careful serve: stopped; every recording is closed" in out
    assert "Traceback" not in out and "Error" not in out, out


@pytest.mark.parametrize("options, message", [
    (["--host", ""], "--host needs an address"),
    (["--host", "  "], "--host needs an address"),
    (["--links", "1000000000"], "--links 1,000,000,000 is more than one start may add"),
])
def test_options_that_cannot_serve_are_one_line_and_exit_2(tmp_path, capsys, options, message) -> None:
    study = write_web_study(tmp_path)
    assert main(["serve", str(study), "--port", "0", *options]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "data" / "links.csv").exists()


@pytest.fixture
def live(web_study):
    app, _ = web_app(web_study)
    sock = bind("127.0.0.1", 0)
    server = make_server(app, header_timeout_s=0.5)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        thread.join(0.02)
    yield sock.getsockname()[1]
    server.should_exit = True
    thread.join(10)


def read_all(connection: socket.socket) -> bytes:
    connection.settimeout(10)
    data = b""
    while chunk := connection.recv(4096):
        data += chunk
    return data


def test_a_request_head_never_finished_is_dropped(live) -> None:
    with socket.create_connection(("127.0.0.1", live)) as connection:
        connection.sendall(b"GET / HTTP/1.1\r\nHost: x\r\nX-Slow: ")
        assert read_all(connection) == b"", "the server closed the connection without an answer"


def test_uvicorns_own_400_has_the_policy_and_the_error_shape(live) -> None:
    with socket.create_connection(("127.0.0.1", live)) as connection:
        connection.sendall(b"NOT HTTP AT ALL\r\n\r\n")
        head, _, body = read_all(connection).partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 400")
    assert b"content-security-policy: default-src 'none'" in head.lower()
    assert set(json.loads(body)) == {"error"}
