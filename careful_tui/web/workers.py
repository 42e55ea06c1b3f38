"""`careful serve --workers N`: N worker processes on one listening socket.

The parent binds the socket, draws the seat files' key (`careful_tui.web.seat_files`) and starts
N processes (multiprocessing's spawn: each imports the package afresh and loads the study
itself); the kernel hands each new connection to one of them. Any worker serves any request,
as the pages' seats live in files. The parent only watches: a worker that ends is started
again (unless it ends within `EARLY_S` of its start, which would repeat: then everything stops),
and Ctrl+C or SIGTERM stops each worker once, which closes every participant's file, and waits.
"""

from __future__ import annotations

import multiprocessing
import os
import secrets
import signal
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

EARLY_S = 5.0
PARENT_CHECK_S = 1.0
STOP_WAIT_S = 20.0


@dataclass(frozen=True)
class WorkerSettings:
    """What each worker needs to build the server (pickled to it, never on its command line).

    Attributes:
        study: the study file's path.
        completion_code: Prolific's, or None.
        prolific: whether Prolific links are taken.
        key: the seat files' HMAC key, drawn by the parent for this run.
    """

    study: Path
    completion_code: str | None
    prolific: bool
    key: bytes


def new_key() -> bytes:
    return secrets.token_bytes(32)


def most_workers() -> int:
    """The largest --workers: four per core."""
    return 4 * (os.cpu_count() or 1)


def run_worker(settings: WorkerSettings, sock: socket.socket, number: int, parent: int,
               make_server: Callable[[Any], Any], say: Callable[[str], None]) -> None:
    """A worker process: the app on `SharedSeats`, served by `make_server`'s uvicorn server on the socket of
    its `parent` (process id) until a signal, or until the parent is gone; `say` is the console's line."""
    from careful_tui.web.links import read_links
    from careful_tui.web.seat_files import SharedSeats
    from careful_tui.web.server import make_app
    from irl_core.studies.study import load_study

    study = load_study(settings.study)
    seats = SharedSeats(study, key=settings.key, say=say)
    app = make_app(study, links=read_links(study), completion_code=settings.completion_code, say=say,
                   seats=seats, prolific=settings.prolific, worker=number)
    server = make_server(app)

    def orphaned() -> None:
        # A parent ended by SIGKILL cannot stop its workers: each stops itself, every seat released as at a stop.
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK_S)
        server.should_exit = True

    threading.Thread(target=orphaned, daemon=True).start()
    server.run(sockets=[sock])


def supervise(settings: WorkerSettings, sock: socket.socket, *, workers: int, say: Callable[[str], None],
              make_server: Callable[[Any], Any]) -> int:
    """Run `workers` worker processes on `sock` until SIGINT or SIGTERM; 0, or 1 when a worker could not start.

    `make_server` (the app's uvicorn server) and `say` go to each worker by name: module-level functions.
    """
    spawn = multiprocessing.get_context("spawn")
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}

    def start(number: int) -> tuple[multiprocessing.process.BaseProcess, float]:
        process = spawn.Process(target=run_worker, args=(settings, sock, number, os.getpid(), make_server, say),
                                name=f"careful serve worker {number}")
        process.start()
        return process, time.monotonic()

    running = [start(number) for number in range(1, workers + 1)]
    failed = False
    try:
        while not stop.wait(0.5):
            for index, (process, since) in enumerate(running):
                if process.is_alive():
                    continue
                if time.monotonic() - since < EARLY_S:
                    say(f"careful serve: worker {index + 1} ended as it started (exit {process.exitcode}); stopping")
                    failed = True
                    stop.set()
                    break
                say(f"careful serve: worker {index + 1} ended (exit {process.exitcode}); starting another")
                running[index] = start(index + 1)
    finally:
        for process, _ in running:
            if process.is_alive() and process.pid is not None:
                os.kill(process.pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_WAIT_S
        for process, _ in running:
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                say(f"careful serve: a worker did not stop in {STOP_WAIT_S:.0f} s; ended")
                process.kill()
                process.join()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 1 if failed else 0
