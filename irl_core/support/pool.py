"""A stoppable process pool whose workers die with the process that started them.

`run_in_pool` runs calls in a pool of worker processes (the bootstrap's resamples, the study
report's fits). Two promises:

- It stops early: leaving (`Stopped`, Ctrl+C, an error) drops the queued calls and tells the
  running ones to stop at their solvers' next check (`irl_core.support.stopping`).
- No worker outlives the process that called `run_in_pool` (its owner), whatever ends it
  (SIGTERM, SIGKILL, a crash): a worker blocked on its queue would otherwise wait forever,
  holding its memory. A forked worker asks the kernel to kill it when its parent goes (Linux's
  ``prctl(PR_SET_PDEATHSIG)``); on every system, and for a worker forked by the fork server
  (whose parent is the server, which lives as long as its workers do), a watchdog thread in the
  worker sees the owner gone and ends the worker within `WATCHDOG_S`.

Workers are forked from this process when it has a single thread (quick, and a script without
a main guard still works), else from a server that has imported the work's module once
(forking beside threads, such as the fit view's, is unsafe).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import itertools
import multiprocessing
import multiprocessing.synchronize
import os
import pickle
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import TypeVar

from irl_core.support.allocator import keep_freed_memory
from irl_core.support.stopping import stop_if_asked, stop_when

# While the workers run, this process asks its stop check this often (seconds).
STOP_POLL_S = 0.1
# Calls handed to the pool ahead of the workers, per worker: each is pickled as it is handed over, and the rest wait
# as they are, not as a second copy.
IN_FLIGHT = 2
# A worker whose parent has gone ends within this many seconds (where the kernel does not end it first).
WATCHDOG_S = 0.25
_PR_SET_PDEATHSIG = 1

T = TypeVar("T")


def run_in_pool(function: Callable[..., T], calls: list[tuple], *, workers: int,
                on_result: Callable[[int, T], None], initializer: Callable[..., None] | None = None,
                initargs: tuple = (), preload: tuple[str, ...] = ()) -> None:
    """`function(*calls[i])` for every i in a pool of `workers` processes (each first running
    `initializer(*initargs)`); `on_result(i, result)` in this process as each comes back. `preload`:
    modules a fork server imports once besides `function`'s (where `function` is a wrapper).

    The workers hear this process's stop: while waiting it asks this thread's stop check every
    STOP_POLL_S, and leaving early (`Stopped`, Ctrl+C, an error, also from `on_result`) drops the
    queued calls and stops the running ones at their solvers' next check, instead of waiting for
    them all (65 s of a 16x16 world's 200 resamples; 24 s of a 26-fit study report). The workers
    die with this process however it ends (see the module's docstring).
    """
    context = process_context()
    if context.get_start_method() == "forkserver":
        context.set_forkserver_preload([__name__, function.__module__, *preload])
    waiting = iter(enumerate(calls))
    futures: dict[Future, int] = {}

    def send(count: int) -> None:
        # Each call is pickled here, so that one that cannot be raises in this thread: pickled by the pool's
        # feeder thread, its error left shutdown(cancel_futures=True) waiting for ever (CPython gh-116685).
        for i, call in itertools.islice(waiting, count):
            futures[pool.submit(_heeding_the_stop, pickle.dumps((function, call), pickle.HIGHEST_PROTOCOL))] = i

    with contextlib.ExitStack() as stack:
        with _stderr_with_a_descriptor():  # the pool (and the stop signal's semaphore) start their helpers here
            stopping = context.Event()
            pool = stack.enter_context(ProcessPoolExecutor(
                max_workers=workers, mp_context=context, initializer=_start_worker,
                initargs=(os.getpid(), stopping, initializer, initargs)))
        try:
            with _stderr_with_a_descriptor():
                send(IN_FLIGHT * workers)  # at least one call per worker: every worker starts here
            while futures:
                finished, _ = wait(set(futures), timeout=STOP_POLL_S, return_when=FIRST_COMPLETED)
                stop_if_asked()
                for future in finished:
                    on_result(futures.pop(future), future.result())
                send(len(finished))
        except BaseException:
            stopping.set()
            pool.shutdown(cancel_futures=True)
            raise


_STOPPING: Callable[[], bool] | None = None  # in a worker of `run_in_pool`: its parent's stop signal


def _start_worker(owner: int, stopping: multiprocessing.synchronize.Event,
                  initializer: Callable[..., None] | None, initargs: tuple) -> None:
    global _STOPPING
    die_with(owner)
    keep_freed_memory()  # the workers' fits make and free many mid-sized arrays
    _STOPPING = stopping.is_set
    if initializer is not None:
        initializer(*initargs)


def _heeding_the_stop(pickled: bytes) -> object:
    """The pickled (function, call)'s function(*call), stopped at its solvers' next check once the parent asks."""
    assert _STOPPING is not None
    function, call = pickle.loads(pickled)
    with stop_when(_STOPPING):
        return function(*call)


def die_with(owner: int) -> None:
    """End this process when process `owner` ends: the kernel's parent-death signal where
    `owner` is the parent on Linux, and a watchdog thread everywhere. Called first in a worker."""
    if owner == os.getppid() and sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if not _alive(owner):  # gone before the signal was asked for
        os._exit(1)
    threading.Thread(target=_watch, args=(owner,), name="owner-watchdog", daemon=True).start()


def _watch(owner: int) -> None:
    while _alive(owner):
        time.sleep(WATCHDOG_S)
    os._exit(1)


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, killed but not yet reaped, does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as file:
            return file.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


@contextlib.contextmanager
def _stderr_with_a_descriptor() -> Iterator[None]:
    """Starting workers passes sys.stderr's file descriptor on; where sys.stderr has none (a Textual
    app or a test capture replaces it), lend it the process's own stderr while they start."""
    try:
        usable = sys.stderr.fileno() >= 0
    except (AttributeError, OSError, ValueError):
        usable = False
    if usable or sys.__stderr__ is None:
        yield
        return
    saved, sys.stderr = sys.stderr, sys.__stderr__
    try:
        yield
    finally:
        sys.stderr = saved


def process_context() -> multiprocessing.context.BaseContext:
    """Fork when this process has one thread (quick, and a script without a main guard still
    works); otherwise fork from a server (`run_in_pool` has it import the work's module once;
    forking beside other threads, such as the fit view's, can deadlock)."""
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    if "forkserver" not in methods:
        return multiprocessing.get_context("spawn")
    return multiprocessing.get_context("forkserver")
