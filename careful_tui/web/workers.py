"""`careful serve --workers N`: N worker processes on one listening socket.

The parent reads the study (its file and every world it names) and links.csv once, binds the
socket, holds the out folder (`careful_tui.web.serving_lock`), draws the seat files' key
(`careful_tui.web.seat_files`) and starts N processes (multiprocessing's spawn), handing each
all of these: a worker started again later serves what the server started with, whatever has
become of the files since. The kernel hands each new connection to one of them. Any worker
serves any request, as the pages' seats live in files.

The parent only watches. A worker that ends is started again, however it ended (a signal, the
kernel's out-of-memory killer, a crash), except one that ended by itself before it was serving:
that is a start-up failure (a broken install, an import error), which would repeat, so everything
stops. Ctrl+C or SIGTERM stops each worker once, which closes every participant's file, and waits.
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
from multiprocessing.synchronize import Event as EventType
from typing import Any

from careful_tui.web.serving_lock import ServingLock
from irl_core.studies.study import LoadedStudy

PARENT_CHECK_S = 1.0
STOP_WAIT_S = 20.0


@dataclass(frozen=True)
class WorkerSettings:
    """What each worker needs to build the server, read by the parent once (pickled to each worker as it
    starts, never on its command line).

    Attributes:
        study: the study, as the parent loaded it.
        links: token -> participant id, as the parent read links.csv.
        completion_code: Prolific's, or None.
        prolific: whether Prolific links are taken.
        key: the seat files' HMAC key, drawn by the parent for this run.
        forwarded_allow_ips: the proxies whose X-Forwarded-For is trusted (`--forwarded-allow-ips`).
    """

    study: LoadedStudy
    links: dict[str, str]
    completion_code: str | None
    prolific: bool
    key: bytes
    forwarded_allow_ips: tuple[str, ...]


def new_key() -> bytes:
    return secrets.token_bytes(32)


def most_workers() -> int:
    """The largest --workers: four per core."""
    return 4 * (os.cpu_count() or 1)


def run_worker(settings: WorkerSettings, sock: socket.socket, held: ServingLock | None, number: int, parent: int,
               serving: EventType, make_server: Callable[..., Any], say: Callable[[str], None]) -> None:
    """A worker process: the app on `SharedSeats`, served by `make_server`'s uvicorn server on the socket of
    its `parent` (process id) until a signal, or until the parent is gone; `serving` is set once it serves,
    `held` (the out folder's lock) is kept until it ends, and `say` is the console's line."""
    from careful_tui.web.seat_files import SharedSeats
    from careful_tui.web.server import make_app

    seats = SharedSeats(settings.study, key=settings.key, say=say)
    app = make_app(settings.study, links=settings.links, completion_code=settings.completion_code, say=say,
                   seats=seats, prolific=settings.prolific, worker=number)
    server = make_server(app, forwarded_allow_ips=settings.forwarded_allow_ips, on_started=serving.set)

    def orphaned() -> None:
        # A parent ended by SIGKILL cannot stop its workers: each stops itself, every seat released as at a stop.
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK_S)
        server.should_exit = True

    threading.Thread(target=orphaned, daemon=True).start()
    # `held` asks nothing more: its descriptor, and so the out folder's lock, stays open until this process ends.
    server.run(sockets=[sock])


@dataclass
class _Worker:
    """A worker process, and whether it has served (set by the worker once its server has started)."""

    process: multiprocessing.process.BaseProcess
    serving: EventType


def supervise(settings: WorkerSettings, sock: socket.socket, *, workers: int, say: Callable[[str], None],
              make_server: Callable[..., Any], held: ServingLock | None = None) -> int:
    """Run `workers` worker processes on `sock` until SIGINT or SIGTERM; 0, or 1 when a worker could not start.

    `make_server` (the app's uvicorn server) and `say` go to each worker by name: module-level functions;
    `held` (the out folder's lock, `careful_tui.web.serving_lock`) goes to each worker as a descriptor.
    """
    spawn = multiprocessing.get_context("spawn")
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}

    def start(number: int) -> _Worker:
        serving = spawn.Event()
        process = spawn.Process(target=run_worker, name=f"careful serve worker {number}",
                                args=(settings, sock, held, number, os.getpid(), serving, make_server, say))
        process.start()
        return _Worker(process, serving)

    running: list[_Worker] = []
    failed = False
    try:
        running.extend(start(number) for number in range(1, workers + 1))
        while not stop.wait(0.5):
            for index, worker in enumerate(running):
                code = worker.process.exitcode
                if code is None:
                    continue
                if code > 0 and not worker.serving.is_set():
                    say(f"careful serve: worker {index + 1} could not start (exit {code}); stopping")
                    failed = True
                    stop.set()
                    break
                say(f"careful serve: worker {index + 1} {_ended(code)}; starting another")
                running[index] = start(index + 1)
    finally:
        for worker in running:
            if worker.process.is_alive() and worker.process.pid is not None:
                os.kill(worker.process.pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_WAIT_S
        for worker in running:
            worker.process.join(max(0.0, deadline - time.monotonic()))
            if worker.process.is_alive():
                say(f"careful serve: a worker did not stop in {STOP_WAIT_S:.0f} s; ended")
                worker.process.kill()
                worker.process.join()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 1 if failed else 0


def _ended(code: int) -> str:
    """How a worker process ended, from its exit code (negative: the signal that ended it)."""
    if code >= 0:
        return f"ended (exit {code})"
    try:
        return f"was ended by {signal.Signals(-code).name}"
    except ValueError:
        return f"was ended by signal {-code}"
