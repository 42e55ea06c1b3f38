"""`careful serve --workers N`: any worker serves any request of a page, its seat in a file.

Two worker processes serve one participant, each request on a new connection, so the kernel hands
them to either worker: the recording is whole and in order, as one process writes it. A terminal
session is refused while a page of theirs plays between requests; a seat file this server did not
sign is never unpickled; another worker's sweep releases a silent page; workers stop with their
parent, even one killed.
"""

from __future__ import annotations

import collections
import json
import os
import pickle
import signal
import time
import urllib.error
import urllib.request

import pytest
from web.conftest import recorded_lines, write_web_study
from web.test_serve_command import Served, token_of

from careful_tui.cli import main
from careful_tui.web.seat_files import ADDRESS_FILE, SharedSeats
from careful_tui.web.session_adapter import WebSession
from irl_core.errors import ParticipantBusy, SeatRefused
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.participant_lock import participant_lock, seat_path
from irl_core.studies.study import load_study

EPISODES = 5


def post(url: str, body: dict, *, timeout: float = 10) -> tuple[int, str | None, dict]:
    """A request on a connection of its own: (status, the worker that answered, the JSON)."""
    request = urllib.request.Request(url, data=json.dumps(body).encode(), method="POST",
                                     headers={"content-type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as answer:
            return answer.status, answer.headers.get("x-careful-worker"), json.loads(answer.read() or b"{}")
    except urllib.error.HTTPError as error:
        return error.code, error.headers.get("x-careful-worker"), json.loads(error.read() or b"{}")


def worker_pids(pid: int) -> list[int]:
    """The worker processes of the server `pid` (multiprocessing's spawned children, not its resource tracker)."""
    deadline, found = time.monotonic() + 20, []
    while time.monotonic() < deadline and len(found) < 2:
        children = [int(child) for child in open(f"/proc/{pid}/task/{pid}/children").read().split()]
        found = [child for child in children
                 if "spawn_main" in open(f"/proc/{child}/cmdline").read().replace("\0", " ")]
        time.sleep(0.1)
    return found


@pytest.fixture
def two_workers(tmp_path):
    study = write_web_study(tmp_path, practice=1, episodes=EPISODES)
    served = Served(study, "--links", "1", "--workers", "2")
    served.read_until("workers: 2 processes")
    yield served, study
    served.stop()


def test_two_workers_serve_one_participant_and_record_every_step_once_in_order(two_workers) -> None:
    served, study = two_workers
    status, _, started = post(served.url + "/api/start", {"token": token_of(study, "p001")})
    assert status == 200
    page, answered, moves = started["page"], collections.Counter(), 0

    def key(kind: str, **fields) -> dict:
        time.sleep(0.09)  # within the key budget (12 a second)
        status, worker, body = post(served.url + "/api/key", {"page": page, "type": kind, **fields})
        assert status == 200, body
        answered[worker] += 1
        return body["view"]

    t = 0.0
    view = key("space")
    while view["stage"] != "end":
        if view["stage"] == "play" and view["play"]["live"]:
            key("press", key="right", t=t)
            view = key("release", key="right", t=t + 80)
            moves += 1
            t += 200
        else:
            view = key("space")
    assert set(answered) == {"1", "2"}, answered  # both workers served this one page
    served.process.send_signal(signal.SIGINT)
    out, _ = served.process.communicate(timeout=30)
    assert served.process.returncode == 0, out
    assert "careful serve: stopped; every recording is closed" in out and "Traceback" not in out, out
    folder = load_study(study).participant_folder("p001")
    steps = [line for line in recorded_lines(folder) if line["kind"] == "step"]
    ends = [line for line in recorded_lines(folder) if line["kind"] == "episode_end"]
    assert len(steps) == moves == 4 * (1 + EPISODES)
    assert [(end["outcome"], end["terminal_symbol"]) for end in ends] == [("terminal", "G")] * (1 + EPISODES)
    for path in folder.glob("*.jsonl"):
        read_recording(path)  # every line checked
    assert not seat_path(load_study(study), "p001").exists()


def test_workers_stop_when_their_parent_is_killed(two_workers) -> None:
    served, _ = two_workers
    workers = worker_pids(served.process.pid)
    assert len(workers) == 2
    served.process.kill()
    served.process.wait(10)
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and any(os.path.exists(f"/proc/{pid}") and
                                              "zombie" not in open(f"/proc/{pid}/status").read() for pid in workers):
        time.sleep(0.2)
    alive = [pid for pid in workers if os.path.exists(f"/proc/{pid}") and "zombie" not in open(f"/proc/{pid}/status").read()]
    for pid in alive:
        os.kill(pid, signal.SIGKILL)
    assert not alive


@pytest.mark.parametrize("workers", ["0", "100000"])
def test_workers_out_of_range_are_one_line_and_exit_2(tmp_path, capsys, workers) -> None:
    study = write_web_study(tmp_path)
    try:
        code = main(["serve", str(study), "--port", "0", "--workers", workers])
    except SystemExit as exit:  # argparse's own refusal
        code = exit.code
    err = capsys.readouterr().err
    assert code == 2 and "--workers" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "data").exists()


def shared(study, **options) -> SharedSeats:
    return SharedSeats(study, key=b"k" * 32, say=lambda line: None, **options)


def claim(seats: SharedSeats, participant: str = "p001"):
    return seats.claim(participant, lambda: WebSession(seats.study, participant, seed=0))


def begin_and_move(seats: SharedSeats, page: str) -> None:
    """One request that begins the first episode and plays one move right (an 80 ms hold)."""
    with seats.playing(page) as playing:
        playing.take_lock()
        playing.session.space()
        playing.session.press("right", 0.0)
        playing.session.release("right", 80.0)


def test_the_budget_of_new_pages_per_address_is_shared_by_the_workers_and_keeps_no_address(web_study) -> None:
    now = [time.time()]
    first, second = (shared(web_study, wall=lambda: now[0], address_seats=(3, 0.5)) for _ in range(2))

    def open_page(seats: SharedSeats, participant: str, address: str = "203.0.113.7"):
        return seats.claim(participant, lambda: WebSession(seats.study, participant, seed=0), address=address)

    assert open_page(first, "p001") and open_page(second, "p002") and open_page(first, "p003")
    with pytest.raises(SeatRefused) as refused:
        open_page(second, "p004")  # the fourth page from one address, whichever worker takes it
    assert refused.value.status == 429
    assert open_page(second, "p004", address="198.51.100.2")  # another network has its own budget
    kept = (web_study.out / ADDRESS_FILE).read_text()
    assert "203.0.113" not in kept and "198.51" not in kept and len(kept.splitlines()) == 2
    now[0] += 2.0  # one page back at 0.5 a second
    assert open_page(second, "p005")
    now[0] += 60.0  # both budgets full again: forgotten
    assert open_page(first, "p006", address="192.0.2.1")
    assert len((web_study.out / ADDRESS_FILE).read_text().splitlines()) == 1


def test_a_seat_this_server_did_not_sign_is_never_unpickled(web_study, tmp_path) -> None:
    class Planted:
        def __reduce__(self):
            return (open, (str(tmp_path / "planted"), "w"))

    web_study.out.mkdir(parents=True, exist_ok=True)
    body = pickle.dumps({"page": "x", "session": Planted(), "tokens": 24.0, "at": 0.0, "played": True})
    seat_path(web_study, "p001").write_bytes(b"played\n-\n" + b"0" * 64 + b"\n" + body)
    seats = shared(web_study)
    assert seats.keep_alive("p001/x") is False
    seat = claim(seats)  # no seat there: a new one
    assert seat is not None and not (tmp_path / "planted").exists()


def test_a_page_that_played_keeps_a_terminal_session_out_between_requests(web_study) -> None:
    seats = shared(web_study)
    seat = claim(seats)
    with participant_lock(web_study, "p001", holder="careful study run"):
        pass  # opened, not played: no hold yet
    with seats.playing(seat.page) as playing:
        playing.take_lock()
        playing.session.space()
    with pytest.raises(ParticipantBusy, match="a browser page"):
        with participant_lock(web_study, "p001", holder="careful study run"):
            pass
    seats.leave(seat.page, "left (closed the page)")
    with participant_lock(web_study, "p001", holder="careful study run"):
        pass


def test_another_workers_sweep_releases_a_silent_page_and_records_its_episode_as_quit(web_study) -> None:
    now = [time.time()]
    first, second = shared(web_study, wall=lambda: now[0]), shared(web_study, wall=lambda: now[0])
    seat = claim(first)
    begin_and_move(first, seat.page)
    second.release_silent()
    assert first.keep_alive(seat.page)  # heard from just now: kept
    now[0] += second.silent_s + 1
    second.release_silent()
    assert not seat_path(web_study, "p001").exists() and not first.keep_alive(seat.page)
    lines = recorded_lines(web_study.participant_folder("p001"))
    assert [line["kind"] for line in lines] == ["session", "step", "episode_end"]
    assert lines[-1]["outcome"] == "quit"


def test_a_seat_older_than_its_recording_is_dropped_rather_than_number_a_step_twice(web_study) -> None:
    said: list[str] = []
    first = shared(web_study)
    second = SharedSeats(web_study, key=b"k" * 32, say=said.append)
    seat = claim(first)
    begin_and_move(first, seat.page)
    (recording,) = web_study.participant_folder("p001").glob("*.jsonl")
    step = recording.read_text().splitlines()[-1]
    with recording.open("a") as file:  # the next step, written by a worker that died before its seat
        file.write(step.replace('"t":0', '"t":1').replace('"t": 0', '"t": 1') + "\n")
    with second.playing(seat.page) as playing:
        assert playing is None
    assert "behind its recording" in said[-1]


def test_in_chromium_a_page_plays_the_study_through_two_workers_and_a_reload_resumes(tmp_path, page) -> None:
    from web.test_page import MAIN_EPISODE, hold, open_and_begin

    study_path = write_web_study(tmp_path)
    served = Served(study_path, "--links", "1", "--workers", "2")
    try:
        served.read_until("workers: 2 processes")
        study = load_study(study_path)
        folder = study.participant_folder("p001")

        def steps() -> int:
            return len([line for line in recorded_lines(folder) if line["kind"] == "step"]) if folder.exists() else 0

        def to_goal() -> None:
            for _ in range(4):
                before = steps()
                hold(page, "ArrowRight", 30)
                deadline = time.monotonic() + 10
                while steps() == before and time.monotonic() < deadline:
                    time.sleep(0.02)
            page.wait_for_selector("#status .end-G")

        open_and_begin(page, f"{served.url}/p/{token_of(study_path, 'p001')}")
        to_goal()
        page.keyboard.press(" ")
        page.wait_for_selector("text=Practice is over.")
        page.keyboard.press(" ")
        page.locator("#status strong", has_text=MAIN_EPISODE).wait_for()
        hold(page, "ArrowRight", 30)
        deadline = time.monotonic() + 10
        while steps() < 5 and time.monotonic() < deadline:
            time.sleep(0.02)
        page.reload()  # a new page: its seat comes from the files, whichever worker answers
        page.wait_for_selector("text=Welcome back: 1 of 2 episodes are done.")
        page.keyboard.press(" ")
        page.wait_for_selector("#play:not([hidden])")
        to_goal()
        page.keyboard.press(" ")
        page.wait_for_selector("text=That is the end of the study. Thank you!")
        ends = sorted((line["episode"], line["outcome"]) for line in recorded_lines(folder) if line["kind"] == "episode_end")
        assert ends == [(0, "quit"), (0, "terminal"), (1, "terminal")]
    finally:
        served.stop()


def test_a_seat_that_cannot_be_written_is_a_503_with_a_sentence(web_study, monkeypatch) -> None:
    from starlette.testclient import TestClient
    from web.conftest import Api, web_app

    app, tokens = web_app(web_study, seats=shared(web_study))
    with TestClient(app) as client:
        api = Api(client, token=tokens["p001"])
        api.key("space")

        def full(self, participant, record):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(SharedSeats, "_write", full)
        answer = api.key("press", key="right", t=1.0)
        assert answer.status_code == 503 and "cannot save anything just now" in answer.json()["error"]
        assert "Traceback" not in answer.text
