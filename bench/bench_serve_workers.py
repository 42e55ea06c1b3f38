"""200 participants, each in a process of its own, playing at a person's pace against `careful serve --workers 2`.

The server runs as its own process (`careful serve --links N --port 0 --workers W`); each participant
is a `bench.serve_client` process: it opens its link, begins, waits for the common start (so that
200 Python start-ups are not measured), then makes `--moves` moves, one every 0.5 to 1.5 s (a press,
the hold in real time, the release), with a heartbeat every 5 s and now and then a new connection.

It reports the round trip of each move's release (what a participant waits for after letting go:
p50 and p99) against the same move made in-process on a `WebSession` (the game, the recorder's
write, the view; no HTTP, no seat file): what the server adds is the rest. Then it stops the server,
reads every participant's recordings back (each line checked) and checks that every move the
answers reported is recorded exactly once and in order. Target: p99 added under 50 ms on 2 cores.

Run: .venv/bin/python -m bench.bench_serve_workers [--participants N] [--moves N] [--workers W]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

from bench.bench_serve import TARGET_P99_MS, bench_study, percentile, rss_kib
from irl_core.recordings.demonstrations import read_recording


def worker_pids(pid: int) -> list[int]:
    children = [int(child) for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    return [child for child in children if "spawn_main" in Path(f"/proc/{child}/cmdline").read_text()]


def cpu_s(pid: int) -> float:
    """The process's CPU time so far (user + system), in seconds."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=200)
    parser.add_argument("--moves", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--reconnect", type=float, default=0.2, help="a client's chance of a new connection per move")
    args = parser.parse_args()
    folder, study_path, baseline = bench_study("bench-serve-workers-")
    root = str(Path(__file__).parents[1])
    env = {**os.environ, "PYTHONPATH": root}
    server = subprocess.Popen([sys.executable, "-m", "careful_tui.cli", "serve", str(study_path), "--port", "0",
                               "--links", str(args.participants), "--workers", str(args.workers)],
                              stdout=subprocess.PIPE, text=True, env=env)
    output = server.stdout
    assert output is not None, "stdout=PIPE"
    console: list[str] = []
    clients: list[subprocess.Popen] = []
    try:
        first = output.readline()
        port = int(first.split(" at ")[1].split("/ ")[0].rsplit(":", 1)[1])
        threading.Thread(target=lambda: console.extend(output), daemon=True).start()  # keep its pipe drained
        time.sleep(3.0)  # the workers start
        rows = [row.split(",") for row in (folder / "data" / "links.csv").read_text().splitlines()[1:]]
        begin_at = time.time() + 10 + args.participants * 0.05
        for i, (participant, token, _) in enumerate(rows):
            clients.append(subprocess.Popen(
                [sys.executable, "-m", "bench.serve_client", "--port", str(port), f"--token={token}",
                 "--moves", str(args.moves), "--begin-at", str(begin_at), "--reconnect", str(args.reconnect),
                 "--seed", str(i), "--source", f"127.0.{1 + i // 250}.{1 + i % 250}",
                 "--out", str(folder / f"{participant}.result.json")], env=env, cwd=root))
        time.sleep(max(0.0, begin_at - time.time()) + 5)
        workers = worker_pids(server.pid) if args.workers > 1 else [server.pid]
        rss_during = sum(rss_kib(pid) for pid in workers)
        cpu_before = sum(cpu_s(pid) for pid in workers)
        start = time.monotonic()
        clients_cpu = 0.0
        for client in clients:
            # wait4 for each client's CPU; Popen is told it was reaped, so it never waits on the pid again.
            _, status, usage = os.wait4(client.pid, 0)
            client.returncode = os.waitstatus_to_exitcode(status)
            clients_cpu += usage.ru_utime + usage.ru_stime
        wall = time.monotonic() - start
        workers_cpu = sum(cpu_s(pid) for pid in workers) - cpu_before
        load = os.getloadavg()[0]
    finally:
        for client in clients:
            if client.poll() is None:
                client.kill()
        server.send_signal(signal.SIGINT)
        server.wait(60)
    results = {participant: json.loads((folder / f"{participant}.result.json").read_text())
               for participant, _, _ in rows if (folder / f"{participant}.result.json").exists()}
    problems = [f"{participant}: no result" for participant, _, _ in rows if participant not in results]
    served_by: collections.Counter[int] = collections.Counter()
    for participant, result in results.items():
        if result["error"]:
            problems.append(f"{participant}: {result['error']}")
        served_by[len([w for w in result["workers"] if w != "?"])] += 1
        paths = sorted((folder / "data" / participant).glob("*.jsonl"))
        steps = []
        for path in paths:
            try:
                recording = read_recording(path)
            except Exception as exc:  # the one line the reader gives, for this participant
                problems.append(f"{participant}: {exc}")
                continue
            steps += list(zip(recording.steps.column("episode").tolist(), recording.steps.column("t").tolist()))
        answered = len(result["reported"])
        if len(steps) != answered:
            problems.append(f"{participant}: {len(steps)} steps recorded, {answered} moves answered")
        if len(set(steps)) != len(steps) or steps != sorted(steps):
            problems.append(f"{participant}: steps recorded twice or out of order")
    releases = [ms for result in results.values() for ms in result["release_ms"]]
    presses = [ms for result in results.values() for ms in result["press_ms"]]
    refused = collections.Counter(tuple(r[:2]) for result in results.values() for r in result["refused"])
    base = statistics.median(baseline)
    p50, p99 = percentile(releases, 0.5), percentile(releases, 0.99)
    print(f"{len(results)} participants in their own processes, {len(releases)} moves in {wall:.1f} s against "
          f"--workers {args.workers}; load average {load:.1f}; refused: {dict(refused) or 'none'}")
    print(f"in-process move (WebSession): p50 {base:.2f} ms, p99 {percentile(baseline, 0.99):.2f} ms")
    print(f"release round trip: p50 {p50:.1f} ms, p99 {p99:.1f} ms, max {max(releases):.1f} ms; press: p50 "
          f"{percentile(presses, 0.5):.1f} ms, p99 {percentile(presses, 0.99):.1f} ms")
    ending = [ms for result in results.values() for ms, ended in zip(result["release_ms"], result["ended"]) if ended]
    going_on = [ms for result in results.values() for ms, ended in zip(result["release_ms"], result["ended"]) if not ended]
    print(f"releases that end an episode (its line fsynced): {len(ending)}, p50 {percentile(ending, 0.5):.1f} ms, "
          f"p99 {percentile(ending, 0.99):.1f} ms; the others p50 {percentile(going_on, 0.5):.1f} ms, "
          f"p99 {percentile(going_on, 0.99):.1f} ms")
    fresh = [ms for result in results.values() for ms, new in zip(result["press_ms"], result["fresh"]) if new]
    kept = [ms for result in results.values() for ms, new in zip(result["press_ms"], result["fresh"]) if not new]
    print(f"presses on a new connection: {len(fresh)}, p99 {percentile(fresh, 0.99):.1f} ms; on a kept one "
          f"p99 {percentile(kept, 0.99):.1f} ms")
    print(f"added p99 {p99 - base:.1f} ms; target < {TARGET_P99_MS:.0f} ms: {'met' if p99 - base < TARGET_P99_MS else 'NOT met'}")
    print(f"participants served by both workers: {served_by.get(2, 0)}, by one: {served_by.get(1, 0)}")
    print(f"CPU while they played: the workers {workers_cpu:.1f} s ({1000 * workers_cpu / max(1, len(releases)):.2f} ms "
          f"a move), the {len(clients)} clients {clients_cpu:.1f} s (start-up included), over {wall:.1f} s on "
          f"{os.cpu_count()} cores")
    print(f"workers' memory with everyone playing: {rss_during / 1024:.1f} MiB in all ({len(workers)} workers)")
    print("every step recorded once, in order; every recording read back" if not problems else
          f"{len(problems)} problems:\n" + "\n".join(problems[:20]))
    print(f"(files in {folder})")


if __name__ == "__main__":
    main()
