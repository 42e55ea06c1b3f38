"""50 participants playing at once against `careful serve` over real HTTP on 127.0.0.1.

The server runs as its own process (`careful serve --links N --port 0`); each simulated
participant is a thread with one keep-alive connection that opens its link, begins, and makes
`--moves` moves (a press, then its release 40-400 ms later on the page's clock), one every
`--pace` seconds, which keeps within the server's key budget. It stops by itself: after the
moves, or at `--limit` seconds.

It reports the server's latency per move (the release's round trip: p50 and p99) against the
same move made in-process on a `WebSession` (the game, the recorder's write, the view; no HTTP),
the server's memory per participant (its resident set after everyone started, less before), and
checks that every step the answers report is recorded exactly once and in order.
Target: p99 under 50 ms on 2 cores while 50 play.

Run: .venv/bin/python -m bench.bench_serve [--participants N] [--moves N] [--pace S]
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import random
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from careful_tui.web.session_adapter import WebSession
from irl_core.studies.study import load_study

STUDY = """\
name = "bench"
worlds = ["paper"]
practice_episodes = 0
episodes = 1000
out = "data"
"""
TARGET_P99_MS = 50.0


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def in_process_ms(study_path: Path, moves: int) -> list[float]:
    """The same moves on a WebSession in this process: what the server adds is the rest."""
    study = load_study(study_path)
    session = WebSession(study, "inproc", seed=1)
    session.space()
    times, t = [], 0.0
    for _ in range(moves):
        session.press("up", t)
        start = time.perf_counter()
        session.release("up", t + 120)
        session.view()
        times.append((time.perf_counter() - start) * 1000)
        t += 300
        if not session.view()["play"]["live"]:
            session.space()
    session.leave()
    return times


def bench_study(prefix: str) -> tuple[Path, Path, list[float]]:
    """A new folder holding `STUDY`, the study file's path, and 200 moves' in-process times on it."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    study_path = folder / "bench.toml"
    study_path.write_text(STUDY)
    return folder, study_path, in_process_ms(study_path, 200)


class Participant(threading.Thread):
    def __init__(self, host: str, port: int, path: str, *, moves: int, pace: float, deadline: float, seed: int):
        super().__init__(daemon=True)
        self.connection = http.client.HTTPConnection(host, port, timeout=30)
        self.connection.connect()
        # http.client sends a request's headers and body in two writes: without this, Nagle's
        # algorithm holds the body until the server's delayed ACK, 40 ms later (a browser does not).
        self.connection.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.path, self.moves, self.pace, self.deadline = path, moves, pace, deadline
        self.rng = random.Random(seed)
        self.latencies: list[float] = []
        self.reported: list[tuple[int, int]] = []  # (episode number shown, step) after each move
        self.refused = 0
        self.started = threading.Event()

    def post(self, path: str, body: dict) -> tuple[int, dict]:
        self.connection.request("POST", path, json.dumps(body), {"content-type": "application/json"})
        answer = self.connection.getresponse()
        data = answer.read()
        return answer.status, json.loads(data) if data else {}

    def run(self) -> None:
        token = self.path.rsplit("/", 1)[1]
        status, started = self.post("/api/start", {"token": token})
        self.started.set()
        if status != 200:
            return
        page, t = started["page"], 1000.0
        self.post("/api/key", {"page": page, "type": "space"})
        for _ in range(self.moves):
            if time.monotonic() > self.deadline:
                break
            key = self.rng.choice(["up", "right", "down", "left"])
            self.post("/api/key", {"page": page, "type": "press", "key": key, "t": t})
            t += self.rng.uniform(40, 400)
            start = time.perf_counter()
            status, answer = self.post("/api/key", {"page": page, "type": "release", "key": key, "t": t})
            self.latencies.append((time.perf_counter() - start) * 1000)
            if status != 200:
                self.refused += 1
                continue
            play = answer["view"].get("play")
            if play is not None:
                self.reported.append((play["episode"], play["step"]))
                if not play["live"]:
                    self.post("/api/key", {"page": page, "type": "space"})
            time.sleep(self.pace)
        self.post("/api/leave", {"page": page})


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=50)
    parser.add_argument("--moves", type=int, default=30)
    parser.add_argument("--pace", type=float, default=0.2, help="seconds between a participant's moves")
    parser.add_argument("--limit", type=float, default=60.0, help="stop after this many seconds")
    args = parser.parse_args()
    folder, study_path, baseline = bench_study("bench-serve-")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1])}
    server = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", "serve", str(study_path), "--port", "0",
                               "--links", str(args.participants)], stdout=subprocess.PIPE, text=True, env=env)
    output = server.stdout
    assert output is not None, "stdout=PIPE"
    try:
        first = output.readline()
        port = int(first.split(" at ")[1].split("/ ")[0].rsplit(":", 1)[1])
        threading.Thread(target=output.read, daemon=True).start()  # keep its pipe drained
        time.sleep(0.5)
        rss_before = rss_kib(server.pid)
        rows = (folder / "data" / "links.csv").read_text().splitlines()[1:]
        deadline = time.monotonic() + args.limit
        players = [Participant("127.0.0.1", port, row.split(",")[2], moves=args.moves, pace=args.pace,
                               deadline=deadline, seed=i) for i, row in enumerate(rows)]
        start = time.monotonic()
        for player in players:
            player.start()
        for player in players:
            player.started.wait(30)
        time.sleep(1.0)
        rss_during = rss_kib(server.pid)
        for player in players:
            player.join(args.limit + 30)
        wall = time.monotonic() - start
    finally:
        server.terminate()
        server.wait(30)
    latencies = [ms for player in players for ms in player.latencies]
    problems = []
    for player, row in zip(players, rows):
        participant = row.split(",")[0]
        lines = [json.loads(line) for path in sorted((folder / "data" / participant).glob("*.jsonl"))
                 for line in path.read_text().splitlines()]
        steps = [(line["episode"], line["t"]) for line in lines if line["kind"] == "step"]
        if len(steps) != len(player.reported):
            problems.append(f"{participant}: {len(steps)} steps recorded, {len(player.reported)} moves answered")
        if len(set(steps)) != len(steps) or steps != sorted(steps):
            problems.append(f"{participant}: steps recorded twice or out of order")
    p50, p99 = percentile(latencies, 0.5), percentile(latencies, 0.99)
    base = statistics.median(baseline)
    print(f"{len(players)} participants, {len(latencies)} moves in {wall:.1f} s "
          f"({sum(p.refused for p in players)} refused), load average {os.getloadavg()[0]:.1f}")
    print(f"in-process move (WebSession): p50 {base:.2f} ms, p99 {percentile(baseline, 0.99):.2f} ms")
    print(f"over HTTP: p50 {p50:.1f} ms, p99 {p99:.1f} ms; added p50 {p50 - base:.1f} ms "
          f"({p50 / base:.0f}x the in-process move); target p99 < {TARGET_P99_MS:.0f} ms: "
          f"{'met' if p99 < TARGET_P99_MS else 'NOT met'}")
    print(f"server memory: {rss_before / 1024:.1f} MiB before, {rss_during / 1024:.1f} MiB with everyone playing, "
          f"{(rss_during - rss_before) / max(1, len(players)):.0f} KiB per participant")
    print("every step recorded once, in order" if not problems else "\n".join(problems))


if __name__ == "__main__":
    main()
