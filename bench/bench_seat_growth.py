"""A long block through `careful serve`'s two kinds of seats: does a move slow down as the block grows?

The seat file of `--workers N` holds the lines of the recording being written (the recorder keeps them to
recover from a deleted file), so it grows with the block. One participant plays one main block of
`--episodes` episodes of 200 steps (bumping a wall until the step limit) through Starlette's test client,
in this process, with one process's seats and with seats in files; the key budget is lifted so that the
moves play in seconds rather than at a person's pace. It reports a move's press and release (median of
moves 100 to 300 and of the last 200), the seat file's size before the block's last step, and the steps
recorded.

Run: .venv/bin/python -m bench.bench_seat_growth [--episodes 10]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from starlette.testclient import TestClient

from careful_tui.web.links import add_links, read_links
from careful_tui.web.seat_files import SharedSeats
from careful_tui.web.seats import KeyBudget, Seats
from careful_tui.web.server import make_app
from irl_core.recordings.demonstrations import read_recording
from irl_core.studies.study import load_study

HALL = 'name = "hall"\nlayout = "....G"\nlevels = 14\nslip = "none"\nstart = [0, 0]\nterminal = ["G"]\n' \
       'rewards = { G = 100.0 }\n'
STUDY = 'name = "long"\nworlds = ["hall.toml"]\npractice_episodes = 0\nepisodes = {episodes}\nout = "data"\n'
STEP_LIMIT = 200


def play(kind: str, episodes: int) -> dict:
    folder = Path(tempfile.mkdtemp(prefix="careful-seat-growth-"))
    (folder / "hall.toml").write_text(HALL)
    (folder / "study.toml").write_text(STUDY.format(episodes=episodes))
    study = load_study(folder / "study.toml")
    add_links(study, 1)
    links = read_links(study)
    seats = Seats() if kind == "one process" else SharedSeats(study, key=b"k" * 32, say=lambda line: None)
    app = make_app(study, links=links, say=lambda line: None, seed=0, seats=seats)
    times = []
    with TestClient(app) as client:
        page = client.post("/api/start", json={"token": next(iter(links))}).json()["page"]

        def key(kind: str, **fields) -> None:
            assert client.post("/api/key", json={"page": page, "type": kind, **fields}).status_code == 200

        key("space")  # begin
        t = 1000.0
        for i in range(episodes * STEP_LIMIT):
            start = time.perf_counter()
            key("press", key="up", t=t)
            key("release", key="up", t=t + 80)  # up bumps the wall: a step that ends nothing
            times.append(time.perf_counter() - start)
            t += 200
            if i == episodes * STEP_LIMIT - 2:
                seat = sorted((folder / "data").glob(".*.seat"))  # before the last step ends the block's file
                size = seat[0].stat().st_size if seat else 0
            if i % STEP_LIMIT == STEP_LIMIT - 1:
                key("space")  # the step limit ended the episode: on to the next
    steps = sum(len(read_recording(path).steps) for path in (folder / "data").rglob("*.jsonl"))
    return {"kind": kind, "early_ms": statistics.median(times[100:300]) * 1000,
            "late_ms": statistics.median(times[-200:]) * 1000, "seat_kib": size / 1024, "steps": steps,
            "moves": len(times)}


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, prog="bench_seat_growth", description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=10, help="200-step episodes in the block (default 10)")
    args = parser.parse_args()
    # A person's pace would take half an hour a block; the budget is the server's guard, not what is measured.
    defaults = KeyBudget.__init__.__kwdefaults__
    assert defaults is not None, "KeyBudget takes burst and rate by keyword"
    defaults.update(burst=10**9, rate=1e9)
    for kind in ("one process", "seats in files"):
        row = play(kind, args.episodes)
        print(f"{row['kind']:>15}: a move {row['early_ms']:.2f} ms early in the block (moves 100-300), "
              f"{row['late_ms']:.2f} ms at its end (the last 200 of {row['moves']}); seat file before the last step "
              f"{row['seat_kib']:.0f} KiB; {row['steps']} steps recorded", flush=True)
        assert row["steps"] == row["moves"], "every move is one recorded step"


if __name__ == "__main__":
    main()
