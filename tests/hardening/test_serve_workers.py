"""`careful serve --workers N` against what issue 45 found (items 1, 2, 3, 5, 6): a step numbered twice when a
seat write is lost, two servers on one out folder, a worker killed as it starts, X-Forwarded-For from anyone,
a restarted worker reading a study file edited since the start."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from web.conftest import write_web_study
from web.test_serve_command import ROOT, Served, token_of
from web.test_workers import begin_and_move, claim, post, worker_pids

from careful_tui.cli import main
from careful_tui.commands.serve import bind, make_server
from careful_tui.web.seat_files import ADDRESS_FILE, SharedSeats
from careful_tui.web.seats import Seats
from careful_tui.web.server import make_app
from careful_tui.web.workers import WorkerSettings, new_key, supervise
from irl_core.errors import SeatUnavailable
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study

# ---------------------------------------------------------------------- item 1: a seat write lost


@pytest.mark.parametrize("lost", ["the worker died before writing the seat", "the disk was full"])
def test_a_step_is_never_numbered_twice_when_another_workers_seat_write_is_lost(tmp_path, monkeypatch, lost):
    """Worker B plays a key (its step appended) and its seat never lands; the page's next key reaches worker A,
    whose seat in memory still matches the file: it must see the recording ahead and not write that step's t
    again (the old code did: `t: 15 repeats a step`, the participant's file left out of the report)."""
    web_study = load_study(write_web_study(tmp_path))
    said: list[str] = []
    first = SharedSeats(web_study, key=b"k" * 32, say=said.append)
    second = SharedSeats(web_study, key=b"k" * 32, say=lambda line: None)
    seat = claim(first)
    begin_and_move(first, seat.page)  # the first worker wrote the seat last: it keeps it in memory

    def lose(participant, record):
        if lost == "the disk was full":
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(second, "_write", lose)
    with contextlib.suppress(SeatUnavailable), second.playing(seat.page) as playing:
        playing.session.press("right", 200.0)
        playing.session.release("right", 280.0)
    with first.playing(seat.page) as playing:  # the page's next key
        if playing is not None:
            playing.session.press("right", 400.0)
            playing.session.release("right", 480.0)
    recordings = sorted(web_study.participant_folder("p001").glob("*.jsonl"))
    for path in recordings:
        read_recording(path)  # every step numbered once
    assert playing is None and any("behind its recording" in line for line in said), said
    again = claim(first)  # the page reloads and resumes where the files say
    assert again is not None
    begin_and_move(first, again.page)
    assert len(recordings) == 1 and len(list(web_study.participant_folder("p001").glob("*.jsonl"))) == 2
    for path in web_study.participant_folder("p001").glob("*.jsonl"):
        read_recording(path)


# ---------------------------------------------------------------------- item 2: one server per out folder


def serve_command(study: Path, *options: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1"}
    return subprocess.run([sys.executable, "-m", "careful_tui.cli", "serve", str(study), "--port", "0", *options],
                          capture_output=True, text=True, env=env, timeout=60)


@pytest.mark.parametrize("first, second", [("2", "2"), ("1", "2"), ("2", "1")])
def test_a_second_server_on_one_out_folder_is_refused_whatever_the_workers(tmp_path, first, second):
    study = write_web_study(tmp_path)
    served = Served(study, "--links", "1", "--workers", first)
    try:
        status, started = served.post("/api/start", {"token": token_of(study, "p001")})
        assert status == 200
        assert served.post("/api/key", {"page": started["page"], "type": "space"})[0] == 200
        out = tmp_path / "data"
        before = {path.name: path.read_bytes() for path in out.iterdir() if path.is_file()}
        run = serve_command(study, "--links", "1", "--workers", second)
        lines = run.stderr.strip().splitlines()
        assert run.returncode == 2 and len(lines) == 1, run.stderr + run.stdout
        assert "is served already by careful serve" in lines[0] and f"process {served.process.pid} " in lines[0]
        assert "Traceback" not in run.stdout + run.stderr
        # Nothing touched: links.csv, every seat, the address budget; the first page plays on.
        after = {path.name: path.read_bytes() for path in out.iterdir() if path.is_file()}
        assert {name: data for name, data in after.items() if name != ".serving"} == \
               {name: data for name, data in before.items() if name != ".serving"}
        assert served.post("/api/key", {"page": started["page"], "type": "press", "key": "right", "t": 1.0})[0] == 200
    finally:
        served.stop()


def open_files(pid: int) -> list[str]:
    """What the process `pid` has open now (a descriptor closed while listed is left out)."""
    found = []
    for fd in os.listdir(f"/proc/{pid}/fd"):
        with contextlib.suppress(FileNotFoundError):
            found.append(os.readlink(f"/proc/{pid}/fd/{fd}"))
    return found


def test_each_worker_holds_the_out_folder_so_a_killed_parent_keeps_it_until_they_end(tmp_path):
    study = write_web_study(tmp_path)
    served = Served(study, "--links", "1", "--workers", "2")
    try:
        served.read_until("workers: 2 processes")
        serving = str(tmp_path / "data" / ".serving")
        workers = worker_pids(served.process.pid)
        assert len(workers) == 2
        for pid in workers:
            assert serving in open_files(pid), pid
    finally:
        served.stop()


# ---------------------------------------------------------------------- item 3: a worker killed as it starts


def test_a_worker_killed_as_it_starts_is_started_again_and_the_server_serves_on(tmp_path):
    study = write_web_study(tmp_path)
    served = Served(study, "--links", "1", "--workers", "2")
    try:
        served.read_until("workers: 2 processes")
        workers = worker_pids(served.process.pid)
        assert len(workers) == 2
        os.kill(workers[0], signal.SIGKILL)  # within its first second: still importing
        line = served.read_until("careful serve: worker")
        assert line.endswith("was ended by SIGKILL; starting another"), served.lines
        status, started = served.post("/api/start", {"token": token_of(study, "p001")})
        assert status == 200
        assert served.post("/api/key", {"page": started["page"], "type": "space"})[0] == 200
        served.process.send_signal(signal.SIGINT)
        out, _ = served.process.communicate(timeout=30)
    finally:
        served.stop()
    assert served.process.returncode == 0, out
    assert "careful serve: stopped; every recording is closed" in out and "Traceback" not in out, out


def cannot_start(app, **options):
    """A `make_server` that fails as an import would: a start-up failure."""
    raise ImportError("uvicorn is broken")


def test_a_worker_that_cannot_start_stops_the_server(tmp_path, capsys):
    web_study = load_study(write_web_study(tmp_path))
    sock = bind("127.0.0.1", 0)
    try:
        settings = WorkerSettings(study=web_study, links={}, completion_code=None, prolific=True, key=new_key(),
                                  forwarded_allow_ips=())
        code = supervise(settings, sock, workers=2, say=print, make_server=cannot_start)
    finally:
        sock.close()
    out = capsys.readouterr().out
    assert code == 1 and re.search(r"worker \d could not start \(exit 1\); stopping", out), out


# ---------------------------------------------------------------------- item 5: X-Forwarded-For


def serve_in_thread(app, **options):
    sock = bind("127.0.0.1", 0)
    server = make_server(app, **options)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started and thread.is_alive():
        thread.join(0.02)
    return f"http://127.0.0.1:{sock.getsockname()[1]}", server, thread


def start_page(url: str, pid: str, forwarded_for: str | None) -> int:
    body = {"prolific": {"pid": pid, "study_id": "s" * 24, "session_id": "x" * 24}}
    headers = {"content-type": "application/json"} | ({"x-forwarded-for": forwarded_for} if forwarded_for else {})
    request = urllib.request.Request(url + "/api/start", data=json.dumps(body).encode(), method="POST", headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=30) as answer:
            return answer.status
    except urllib.error.HTTPError as error:
        return error.code


@pytest.mark.parametrize("proxies", [(), ("127.0.0.1",)])
def test_forwarded_addresses_count_only_from_a_proxy_named_by_forwarded_allow_ips(tmp_path, proxies):
    """Without a proxy named, a client's own X-Forwarded-For chooses nothing: invented addresses share its one
    budget of new pages (uvicorn trusted it from any loopback peer: 200 invented ids took seats in 0.6 s).
    From a named proxy, each forwarded address has a budget of its own."""
    web_study = load_study(write_web_study(tmp_path))
    app = make_app(web_study, links={}, say=lambda line: None, seats=Seats(address_seats=(2, 1e-6)), prolific=True)
    url, server, thread = serve_in_thread(app, forwarded_allow_ips=proxies)
    try:
        invented = [start_page(url, f"inv{k}", f"203.0.113.{k}") for k in range(3)]
        same = [start_page(url, f"lab{k}", "198.51.100.9") for k in range(3)]
    finally:
        server.should_exit = True
        thread.join(10)
    if proxies:
        assert invented == [200, 200, 200] and same == [200, 200, 429]
    else:
        assert invented == [200, 200, 429] and same == [429, 429, 429]


@pytest.mark.parametrize("options, distinct", [((), 1), (("--forwarded-allow-ips", "127.0.0.1"), 2)])
def test_the_workers_trust_forwarded_addresses_only_from_the_named_proxy(tmp_path, options, distinct):
    """The address budget's file counts one line per address: two forwarded addresses are two only when the
    peer is the proxy named."""
    study = write_web_study(tmp_path)
    served = Served(study, "--prolific", "--workers", "2", *options)
    try:
        served.read_until("workers: 2 processes")
        assert [start_page(served.url, f"x{k}", f"203.0.113.{k}") for k in range(2)] == [200, 200]
        assert len((tmp_path / "data" / ADDRESS_FILE).read_text().splitlines()) == distinct
    finally:
        served.stop()


@pytest.mark.parametrize("value, message", [
    ("nginx", "--forwarded-allow-ips takes IP addresses or networks"),
    ("*", "--forwarded-allow-ips '*'"),
    ("127.0.0.1,", "--forwarded-allow-ips takes IP addresses or networks"),
])
def test_a_forwarded_allow_ips_that_names_no_proxy_is_one_line_and_exit_2(tmp_path, capsys, value, message):
    study = write_web_study(tmp_path)
    assert main(["serve", str(study), "--port", "0", "--forwarded-allow-ips", value]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "data").exists()


# ---------------------------------------------------------------------- item 6: a restarted worker


@pytest.mark.parametrize("edit", ["episodes changed", "half saved"])
def test_a_restarted_worker_serves_the_study_its_server_read_at_the_start(tmp_path, edit):
    """The study file edited while serving, then the workers killed: the workers started again serve what the
    server started with (the old ones read the file again: one participant told 1 episode by one worker and 3
    by another; a half-saved file stopped the server)."""
    study = write_web_study(tmp_path, practice=1, episodes=1)
    served = Served(study, "--links", "2", "--workers", "2")
    try:
        served.read_until("workers: 2 processes")
        assert served.post("/api/start", {"token": token_of(study, "p001")})[0] == 200
        assert served.read_until("p001: opened the page").endswith("(0 of 2 episodes done)")
        text = study.read_text()
        study.write_text(text.replace("episodes = 1", "episodes = 3") if edit == "episodes changed" else text[:40])
        for pid in worker_pids(served.process.pid):
            os.kill(pid, signal.SIGKILL)
        for _ in range(2):
            assert served.read_until("careful serve: worker").endswith("; starting another"), served.lines
        assert post(served.url + "/api/start", {"token": token_of(study, "p002")}, timeout=60)[0] == 200  # waits for a worker
        assert served.read_until("p002: opened the page").endswith("(0 of 2 episodes done)")
    finally:
        served.stop()
