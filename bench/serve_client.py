"""One participant of `bench_serve_workers`, in a process of its own: opens its link, begins, and plays
`--moves` moves at a person's pace (one every 0.5 to 1.5 s: a press, the hold in real time, the release),
with the page's heartbeat every 5 s; a new connection before a move now and then (`--reconnect`), as a
browser's idle connection is closed. Only the standard library, so 200 of these start quickly.

Writes its measurements to `--out` as JSON: each move's press and release round trips (ms), the
(episode, step) each release's answer reported, the refusals, and which worker answered how often.
"""

from __future__ import annotations

import argparse
import collections
import json
import random
import socket
import time

HEARTBEAT_S = 5.0
IDLE_S = 4.0


class Page:
    """A page's requests on one keep-alive connection, written and read by hand: http.client's CPU would be
    counted against the server on these shared cores (a browser's is on another machine)."""

    def __init__(self, host: str, port: int, source: str) -> None:
        self.host, self.port, self.source = host, port, source
        self.sock: socket.socket | None = None
        self.buffer = b""
        self.used = 0.0
        self.workers: collections.Counter[str] = collections.Counter()

    def reconnect(self) -> None:
        if self.sock is not None:
            self.sock.close()
        self.sock = socket.create_connection((self.host, self.port), timeout=60, source_address=(self.source, 0))
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.buffer = b""

    def post(self, path: str, body: dict) -> tuple[int, dict, float]:
        """(status, JSON, round trip in ms); a connection the server closed is opened again once."""
        data = json.dumps(body).encode()
        request = (f"POST {path} HTTP/1.1\r\nHost: {self.host}\r\nContent-Type: application/json\r\n"
                   f"Content-Length: {len(data)}\r\n\r\n").encode() + data
        for attempt in (1, 2):
            # The server closes a connection idle for 5 s (uvicorn's keep-alive); a browser then opens another.
            if self.sock is None or time.monotonic() - self.used > IDLE_S:
                self.reconnect()
            assert self.sock is not None
            start = time.perf_counter()
            try:
                self.sock.sendall(request)
                status, headers, answer = self._response()
            except (ConnectionError, OSError):
                if attempt == 2 or path == "/api/key":  # a key is never sent twice: it could be played twice
                    raise
                self.sock = None
                continue
            self.used = time.monotonic()
            self.workers[headers.get("x-careful-worker", "?")] += 1
            return status, json.loads(answer) if answer else {}, (time.perf_counter() - start) * 1000
        raise AssertionError("unreachable")

    def _response(self) -> tuple[int, dict[str, str], bytes]:
        assert self.sock is not None
        while b"\r\n\r\n" not in self.buffer:
            self._more()
        head, self.buffer = self.buffer.split(b"\r\n\r\n", 1)
        lines = head.decode("latin-1").split("\r\n")
        headers = {name.strip().lower(): value.strip() for name, _, value in (line.partition(":") for line in lines[1:])}
        length = int(headers.get("content-length", "0"))
        while len(self.buffer) < length:
            self._more()
        body, self.buffer = self.buffer[:length], self.buffer[length:]
        return int(lines[0].split()[1]), headers, body

    def _more(self) -> None:
        assert self.sock is not None
        chunk = self.sock.recv(65536)
        if not chunk:
            raise ConnectionResetError("the server closed the connection")
        self.buffer += chunk


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--token", required=True)
    parser.add_argument("--moves", type=int, default=40)
    parser.add_argument("--begin-at", type=float, required=True, help="time.time() at which to start moving")
    parser.add_argument("--reconnect", type=float, default=0.2, help="chance of a new connection before a move")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--source", default="127.0.0.1",
                        help="the loopback address to connect from (participants come from addresses of their own)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    page = Page("127.0.0.1", args.port, args.source)
    result: dict = {"press_ms": [], "release_ms": [], "reported": [], "ended": [], "fresh": [], "refused": [], "error": None}
    try:
        status, started, _ = page.post("/api/start", {"token": args.token})
        if status != 200:
            raise RuntimeError(f"start refused: {status} {started}")
        page_id, t = started["page"], 1000.0
        page.post("/api/key", {"page": page_id, "type": "space"})
        time.sleep(max(0.0, args.begin_at - time.time()) + rng.uniform(0, 1.5))
        heard = time.monotonic()
        for _ in range(args.moves):
            period = rng.uniform(0.5, 1.5)
            began = time.monotonic()
            fresh = rng.random() < args.reconnect
            if fresh:
                page.reconnect()
            key = rng.choice(["up", "right", "down", "left"])
            hold_ms = rng.uniform(40, 400)
            status, answer, press_ms = page.post("/api/key", {"page": page_id, "type": "press", "key": key, "t": t})
            result["press_ms"].append(press_ms)
            result["fresh"].append(fresh)
            if status != 200:
                result["refused"].append(["press", status, answer.get("error")])
            time.sleep(hold_ms / 1000)
            t += hold_ms
            status, answer, release_ms = page.post("/api/key", {"page": page_id, "type": "release", "key": key, "t": t})
            result["release_ms"].append(release_ms)
            if status != 200:
                result["refused"].append(["release", status, answer.get("error")])
            else:
                play = answer["view"].get("play")
                if play is not None:
                    result["reported"].append([play["episode"], play["step"]])
                    result["ended"].append(not play["live"])
                    if not play["live"]:
                        page.post("/api/key", {"page": page_id, "type": "space"})
            if time.monotonic() - heard > HEARTBEAT_S:
                page.post("/api/alive", {"page": page_id})
                heard = time.monotonic()
            time.sleep(max(0.0, period - (time.monotonic() - began)))
            t += 300
        page.post("/api/leave", {"page": page_id})
    except Exception as exc:  # the driver reports it, beside the others' numbers
        result["error"] = f"{type(exc).__name__}: {exc}"
    result["workers"] = dict(page.workers)
    with open(args.out, "w") as out:
        json.dump(result, out)


if __name__ == "__main__":
    main()
