"""`careful serve` as a process: what it prints, Ctrl+C closing every file, SIGKILL losing no
finished step, links.csv appended on a second start, bad options refused in one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from web.conftest import recorded_lines, write_web_study

from careful_tui.cli import main
from irl_core.studies.study import load_study, read_protocol

ROOT = Path(__file__).parents[2]


class Served:
    """`careful serve` in a subprocess on a free port, read line by line."""

    def __init__(self, study: Path, *options: str) -> None:
        env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1"}
        self.process = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", "serve", str(study), "--port", "0", *options],
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        self.lines: list[str] = []
        first = self.read_until("careful serve: study")
        self.url = first.split(" at ")[1].split("/ ")[0]
        self.read_until("recordings:")

    def read_until(self, start: str) -> str:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            line = self.process.stdout.readline()
            if not line:
                break
            self.lines.append(line.rstrip("\n"))
            if line.startswith(start) or f": {start}" in line:
                return line.rstrip("\n")
        raise AssertionError(f"no line {start!r} in {self.lines}")

    def post(self, path: str, body: dict) -> tuple[int, dict]:
        request = urllib.request.Request(self.url + path, data=json.dumps(body).encode(), method="POST",
                                         headers={"content-type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=10) as answer:
                return answer.status, json.loads(answer.read() or b"{}")
        except urllib.error.HTTPError as error:
            return error.code, json.loads(error.read() or b"{}")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(10)


def token_of(study_path: Path, participant: str) -> str:
    rows = (study_path.parent / "data" / "links.csv").read_text().splitlines()
    return next(row.split(",")[1] for row in rows if row.startswith(participant + ","))


def play(served: Served, token: str, moves: int) -> tuple[str, dict]:
    status, started = served.post("/api/start", {"token": token})
    assert status == 200
    page, t = started["page"], 100.0
    served.post("/api/key", {"page": page, "type": "space"})
    view = None
    for _ in range(moves):
        served.post("/api/key", {"page": page, "type": "press", "key": "right", "t": t})
        _, view = served.post("/api/key", {"page": page, "type": "release", "key": "right", "t": t + 80})
        t += 200
        if view["view"]["stage"] == "play" and view["view"]["play"].get("end"):
            served.post("/api/key", {"page": page, "type": "space"})
            served.post("/api/key", {"page": page, "type": "space"})
    return page, view


def test_sigkill_mid_study_keeps_every_finished_step_and_the_participant_resumes(tmp_path):
    study_path = write_web_study(tmp_path)
    served = Served(study_path, "--links", "1")
    try:
        play(served, token_of(study_path, "p001"), moves=6)  # the practice episode (4), 2 moves of the main one
        served.process.send_signal(signal.SIGKILL)
        served.process.wait(10)
    finally:
        served.stop()
    steps = [line for line in recorded_lines(tmp_path / "data" / "p001") if line["kind"] == "step"]
    assert len(steps) == 6
    study = load_study(study_path)
    protocol = read_protocol(study, "p001")
    assert protocol.progress == (1, 2) and protocol.next_block.phase == "main"
    again = Served(study_path)
    try:
        status, started = again.post("/api/start", {"token": token_of(study_path, "p001")})
        assert status == 200
        assert "Welcome back: 1 of 2 episodes are done" in started["view"]["paragraphs"][1]["text"]
    finally:
        again.stop()


def test_it_prints_where_it_listens_the_links_and_each_participant_and_ctrl_c_closes_every_file(tmp_path):
    study_path = write_web_study(tmp_path)
    served = Served(study_path, "--links", "2", "--completion-code", "ABC123", "--prolific")
    try:
        assert served.url.startswith("http://127.0.0.1:")
        assert any(line.startswith("links: 2 new appended to ") and line.endswith("links.csv, 2 in all")
                   for line in served.lines)
        assert any("?PROLIFIC_PID={{%PROLIFIC_PID%}}" in line and "ABC123" in line for line in served.lines)
        play(served, token_of(study_path, "p002"), moves=2)
        served.read_until("p002: started world 1 of 1")
        served.process.send_signal(signal.SIGINT)
        out, _ = served.process.communicate(timeout=20)
    finally:
        served.stop()
    assert served.process.returncode == 0, out
    assert "p002: left (the server stopped)" in out and "careful serve: stopped; every recording is closed" in out
    ends = [line for line in recorded_lines(tmp_path / "data" / "p002") if line["kind"] == "episode_end"]
    assert [end["outcome"] for end in ends] == ["quit"]
    # A second start with --links appends; the first links still open the page.
    first = (tmp_path / "data" / "links.csv").read_text()
    again = Served(study_path, "--links", "1")
    try:
        assert (tmp_path / "data" / "links.csv").read_text().startswith(first)
        with urllib.request.urlopen(f"{again.url}/p/{token_of(study_path, 'p001')}", timeout=10) as answer:
            assert answer.status == 200
        with urllib.request.urlopen(f"{again.url}/p/{token_of(study_path, 'p003')}", timeout=10) as answer:
            assert answer.status == 200
    finally:
        again.stop()


@pytest.mark.parametrize("options, message", [
    (["--completion-code", "a b<c>"], "--completion-code takes Prolific's code as it is"),
    (["--port", "70000"], "must be a port from 0 to 65535"),
])
def test_bad_options_are_one_line_and_exit_2(tmp_path, capsys, options, message):
    study_path = write_web_study(tmp_path)
    with pytest.raises(SystemExit) if "--port" in options else _nothing():
        assert main(["serve", str(study_path), *options]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
