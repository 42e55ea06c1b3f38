"""Web fixtures: a small study, the server on a free loopback port in a thread, and headless Chromium.

The browser is Debian's Chromium driven by Playwright for Python (`.ci/run` installs both);
without either the browser tests are skipped, saying which is missing.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from careful_tui.commands.serve import bind, make_server
from careful_tui.web.links import add_links, read_links
from careful_tui.web.seat_files import SharedSeats
from careful_tui.web.seats import Seats
from careful_tui.web.server import make_app
from irl_core.studies.study import LoadedStudy, load_study

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]
# A hall of four cells and the goal: three moves right reach it (no slips), up bumps the wall and stays.
HALL = """\
name = "hall <i>of</i> <script>alert('w')</script>"
layout = "....G"
levels = 14
slip = "none"
start = [0, 0]
terminal = ["G"]
rewards = { G = 100.0 }
"""
STUDY = """\
name = "web <b>pilot</b>"
instructions = "Reach the goal. <img src=x onerror=alert(1)> is text."
worlds = ["hall.toml"]
practice_episodes = {practice}
episodes = {episodes}
input = "hold"
out = "data"
"""


def write_web_study(folder: Path, *, practice: int = 1, episodes: int = 1) -> Path:
    (folder / "hall.toml").write_text(HALL)
    path = folder / "web.toml"
    path.write_text(STUDY.format(practice=practice, episodes=episodes))
    return path


@pytest.fixture
def web_study(tmp_path: Path) -> LoadedStudy:
    return load_study(write_web_study(tmp_path))


def recorded_lines(folder: Path) -> list[dict]:
    """Every line of every recording in a participant's folder, file by file in name order."""
    return [json.loads(line) for path in sorted(folder.glob("*.jsonl")) for line in path.read_text().splitlines()]


@dataclass
class LiveServer:
    url: str
    study: LoadedStudy
    links: dict[str, str]  # participant -> link
    seats: Seats

    def link(self, participant: str) -> str:
        return self.links[participant]


def start_server(study: LoadedStudy, *, links: int = 2, completion_code: str | None = None,
                 prolific: bool | None = True) -> tuple[LiveServer, object, threading.Thread]:
    add_links(study, links)
    tokens = read_links(study)
    seats = Seats()
    app = make_app(study, links=tokens, completion_code=completion_code, say=lambda line: None, seed=0, seats=seats,
                   prolific=prolific)
    sock = bind("127.0.0.1", 0)
    url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    server = make_server(app)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        thread.join(0.02)
    live = LiveServer(url, study, {p: f"{url}/p/{t}" for t, p in tokens.items()}, seats)
    return live, server, thread


@pytest.fixture
def live_server(web_study: LoadedStudy) -> Iterator[LiveServer]:
    live, server, thread = start_server(web_study, completion_code="C0DE-42")
    yield live
    server.should_exit = True
    thread.join(10)


@pytest.fixture(scope="module")
def browser():
    # Per module, not per session: Playwright's sync API keeps an event loop running in this thread while
    # it is open, and a Textual Pilot test after it in the same run could not start its own.
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is missing (apt-get install chromium; .ci/run installs it)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is missing (pip install playwright; the test extra has it)")
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


@pytest.fixture
def page(browser):
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    page = context.new_page()
    yield page
    context.close()


class Api:
    """The page's requests, made by a test through Starlette's TestClient."""

    def __init__(self, client, *, token: str | None = None, prolific: dict | None = None,
                 user_agent: str = "test-agent/1.0") -> None:
        self.client = client
        self.user_agent = user_agent
        self.t = 1000.0
        body = {"token": token} if token is not None else {"prolific": prolific}
        self.answer = client.post("/api/start", json=body, headers={"user-agent": user_agent})
        self.page = self.answer.json().get("page") if self.answer.status_code == 200 else None
        self.view = self.answer.json().get("view") if self.page else None

    def key(self, kind: str, **fields):
        answer = self.client.post("/api/key", json={"page": self.page, "type": kind, **fields})
        if answer.status_code == 200:
            self.view = answer.json()["view"]
        return answer

    def hold(self, key: str, ms: float):
        """A press and, `ms` later on the page's clock, its release; returns the release's answer."""
        self.key("press", key=key, t=self.t)
        self.t += ms
        answer = self.key("release", key=key, t=self.t)
        self.t += 100
        return answer

    def walk_to_goal(self, ms: float = 60):
        """The hall: four moves right from the start reach the goal."""
        for _ in range(4):
            assert self.hold("right", ms).status_code == 200
        assert self.view["play"]["end"]["code"] == "G"

    def play_the_study(self):
        """The web study from its instructions to its end: begin, the practice episode, on, the main one, on."""
        self.key("space")
        self.walk_to_goal()
        self.key("space"), self.key("space")
        self.walk_to_goal()
        self.key("space")


SEAT_KINDS = ["one process", "seats in files"]


def seats_of_kind(study: LoadedStudy, kind: str) -> Seats | SharedSeats:
    """One process's seats, or the seats every worker of `careful serve --workers N` shares (in files)."""
    return Seats() if kind == "one process" else SharedSeats(study, key=b"k" * 32, say=lambda line: None)


def web_app(study: LoadedStudy, *, links: int = 2, completion_code: str | None = None, **options):
    """The server's app for `study` with `links` links; returns (app, participant -> token)."""
    add_links(study, links)
    tokens = read_links(study)
    app = make_app(study, links=tokens, completion_code=completion_code, say=lambda line: None, seed=0, **options)
    return app, {p: t for t, p in tokens.items()}
