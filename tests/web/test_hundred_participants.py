"""100 participants at once, over real HTTP on 127.0.0.1, all finish with valid files.

The server (uvicorn in a thread, with every bound of `careful serve`) and 100 participant
threads, each with a keep-alive connection: open the link, begin, walk the hall to its goal in
practice and in the main block, and reach the end screen. Then every participant's folder reads
back (every line checked, episode ends against their steps) as the finished study.
"""

from __future__ import annotations

import http.client
import json
import threading
from urllib.parse import urlsplit

from web.conftest import start_server, write_web_study

from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study, read_protocol

PARTICIPANTS = 100


class Participant(threading.Thread):
    def __init__(self, link: str, barrier: threading.Barrier) -> None:
        super().__init__(daemon=True)
        address = urlsplit(link)
        self.connection = http.client.HTTPConnection(address.hostname, address.port, timeout=60)
        self.token = address.path.rsplit("/", 1)[1]
        self.barrier = barrier
        self.problems: list[str] = []
        self.stage = ""

    def post(self, path: str, body: dict) -> dict:
        self.connection.request("POST", path, json.dumps(body), {"content-type": "application/json"})
        answer = self.connection.getresponse()
        data = answer.read()
        if answer.status not in (200, 204):
            self.problems.append(f"{path} {body.get('type', '')}: {answer.status} {data[:200]!r}")
            return {}
        return json.loads(data) if data else {}

    def run(self) -> None:
        self.barrier.wait()  # every participant opens the page at the same moment
        started = self.post("/api/start", {"token": self.token})
        page, t = started.get("page"), 1000.0
        if page is None:
            return
        view = self.post("/api/key", {"page": page, "type": "space"}).get("view", {})
        for _ in range(2):  # practice, then the main block: four moves right reach the goal
            for _ in range(4):
                self.post("/api/key", {"page": page, "type": "press", "key": "right", "t": t})
                view = self.post("/api/key", {"page": page, "type": "release", "key": "right", "t": t + 80}).get("view", {})
                t += 200
            for _ in range(2):
                view = self.post("/api/key", {"page": page, "type": "space"}).get("view", view)
                if view.get("stage") == "end":
                    break
        self.stage = view.get("stage", "")
        self.post("/api/leave", {"page": page})
        self.connection.close()


def test_a_hundred_participants_at_once_all_finish_with_valid_files(tmp_path) -> None:
    study = load_study(write_web_study(tmp_path))
    live, server, thread = start_server(study, links=PARTICIPANTS)
    try:
        barrier = threading.Barrier(PARTICIPANTS)
        players = [Participant(link, barrier) for link in live.links.values()]
        for player in players:
            player.start()
        for player in players:
            player.join(300)
    finally:
        server.should_exit = True
        thread.join(30)
    assert [p.problems for p in players if p.problems] == []
    assert [p.stage for p in players] == ["end"] * PARTICIPANTS
    for participant in live.links:
        assert read_protocol(study, participant).finished, participant
        files = sorted(study.participant_folder(participant).glob("*.jsonl"))
        recordings = [read_recording(path) for path in files]
        assert sum(len(r.steps) for r in recordings) == 8
        assert [end.terminal_symbol for r in recordings for end in r.episode_ends] == ["G", "G"]
