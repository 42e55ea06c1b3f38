"""Where many fits run: one interface over this machine's process pool and a Dask cluster.

An `Executor` runs `function(*shared, *call)` for every call and hands each result back in this process
as it comes (`run`). Two kinds, one a line of `scheduler`:

=================  ==========================================================================
``None``           `LocalPool`: the process pool of `irl_core.support.pool` on this machine's
                   cores (its workers die with this process, and stop when it is left)
``local:N``        `DaskExecutor` on a Dask `LocalCluster` of N worker processes, started here
``tcp://HOST:P``   `DaskExecutor` on the Dask scheduler at that address (a running cluster:
                   ``dask scheduler`` and ``dask worker`` processes, or an existing deployment)
=================  ==========================================================================

`shared` is data every call needs (a world, the episodes): sent once per worker, not once per call.
Results do not depend on the executor: the work is the same calls with the same arguments, so the
same seeds give the same numbers to the last digit (tests/study/test_executor.py holds it).

A Dask worker that dies takes its running tasks with it; the scheduler reruns them on the workers
left (up to `distributed.scheduler.allowed-failures` times). When every worker holding the shared data
dies at once, the calls that need it are sent again with the data (up to `MAX_RESENDS` times). A call
that cannot be rerun is handed to `on_lost` with the reason, so that the caller can say which answers
are missing; without `on_lost` it raises `LostCall`. A cluster lost altogether (no worker for `NO_WORKERS_S`,
or the scheduler gone for good) raises `ClusterLost` naming the calls not done, and connecting to a scheduler
(the connection and Dask's handshake) is bounded by `CONNECT_TIMEOUT_S`. Dask is the optional extra ``careful[cluster]``:
it is imported only here, and only when a scheduler is named.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import logging
import os
import re
import socket
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol, TypeVar, cast

from irl_core.errors import ClusterLost, LostCall, SchedulerError
from irl_core.support.pool import STOP_POLL_S, run_in_pool
from irl_core.support.stopping import stop_if_asked

T = TypeVar("T")
# An address that does not answer is given up after this many seconds (the command line's promise is 10).
CONNECT_TIMEOUT_S = 5.0
LOCAL = re.compile(r"local:(\d+)")
MAX_LOCAL_WORKERS = 256
# A run on a cluster without a single worker for this long is given up (`ClusterLost`): a worker that its
# nanny restarts is back within seconds, and a report must not wait silently for ever.
NO_WORKERS_S = 30.0
# How often a run asks the scheduler how many workers it has.
WORKER_CHECK_S = 1.0
# A call cancelled because every copy of the shared data died with its workers is sent again this many times.
MAX_RESENDS = 3


class Executor(Protocol):
    """Runs calls somewhere and hands their results back here (see the module's docstring)."""

    @property
    def workers(self) -> int:
        """How many calls run at once."""
        ...

    @property
    def remote(self) -> bool:
        """Whether a call costs a message to another process's scheduler (batch small calls)."""
        ...

    def run(self, function: Callable[..., T], calls: Sequence[tuple], *, on_result: Callable[[int, T], None],
            shared: tuple = (), on_lost: Callable[[int, str], None] | None = None) -> None:
        """`function(*shared, *calls[i])` for every i; `on_result(i, result)` here as each comes back."""
        ...


class LocalPool:
    """This machine's process pool (`irl_core.support.pool.run_in_pool`) as an `Executor`."""

    remote = False

    def __init__(self, workers: int | None = None) -> None:
        self.workers = max(1, workers or os.cpu_count() or 1)

    def run(self, function: Callable[..., T], calls: Sequence[tuple], *, on_result: Callable[[int, T], None],
            shared: tuple = (), on_lost: Callable[[int, str], None] | None = None) -> None:
        """See `Executor.run`; a worker process that dies breaks the pool, which raises (no rerun here)."""
        run_in_pool(_with_shared, [(function, call) for call in calls], workers=self.workers, on_result=on_result,
                    initializer=_install_shared, initargs=(shared,), preload=(function.__module__,))


def run_calls(function: Callable[..., T], calls: Sequence[tuple], *, on_result: Callable[[int, T], None],
              shared: tuple = (), workers: int = 1) -> None:
    """`function(*shared, *calls[i])` for every i, on a `LocalPool` of up to `workers` processes (here, in order, with
    one); `on_result(i, result)` here as each comes back, while the others go on."""
    if workers <= 1 or len(calls) <= 1:
        for i, call in enumerate(calls):
            on_result(i, function(*shared, *call))
        return
    LocalPool(min(workers, len(calls))).run(function, calls, on_result=on_result, shared=shared)


def map_calls(function: Callable[..., T], calls: Sequence[tuple], *, shared: tuple = (), workers: int = 1) -> list[T]:
    """[function(*shared, *call) for call in calls], on a `LocalPool` of up to `workers` processes (here with one)."""
    out: list[T | None] = [None] * len(calls)
    run_calls(function, calls, on_result=out.__setitem__, shared=shared, workers=workers)
    return cast("list[T]", out)


_SHARED: tuple = ()  # in a worker of `LocalPool`: the run's shared data


def _install_shared(shared: tuple) -> None:
    global _SHARED
    _SHARED = shared


def _with_shared(function: Callable[..., T], call: tuple) -> T:
    return function(*_SHARED, *call)


class DaskExecutor:
    """A Dask distributed client as an `Executor` (`scheduler` opens one)."""

    remote = True

    def __init__(self, client: Any, *, cluster: Any = None, address: str = "",
                 quiet: contextlib.ExitStack | None = None) -> None:
        self.client, self.cluster, self.address = client, cluster, address
        self.quiet = quiet or contextlib.ExitStack()  # Dask's logs silenced until `close`

    @property
    def workers(self) -> int:
        """The cluster's worker threads now (at least 1)."""
        threads = self.client.nthreads()
        return max(1, sum(threads.values()))

    def run(self, function: Callable[..., T], calls: Sequence[tuple], *, on_result: Callable[[int, T], None],
            shared: tuple = (), on_lost: Callable[[int, str], None] | None = None) -> None:
        """See `Executor.run`. Leaving early (`Stopped`, Ctrl+C, an error) cancels the calls not yet done.

        Raises `ClusterLost` (the calls not done in `missing`) when the cluster has had no worker for
        `NO_WORKERS_S`, or when the client lost its scheduler and could not reconnect within `CONNECT_TIMEOUT_S`."""
        import distributed

        scattered: list[Any] = []
        futures: dict[Any, int] = {}  # pending future -> its call's index
        resent = [0] * len(calls)
        watch = _WorkerWatch(self.client)

        def send(indices: Sequence[int]) -> None:
            # Scattered data lives only on workers: when every worker holding it dies, the scheduler cannot
            # recompute it and cancels the calls that need it. Those calls are sent again with the data.
            shared_now = [self.client.scatter(item, broadcast=True, hash=False) for item in shared]
            scattered.extend(shared_now)
            for i in indices:
                futures[self.client.submit(function, *shared_now, *calls[i], pure=False)] = i

        waiting: list[int] = []  # cancelled calls, sent again once the scheduler and a worker are there
        try:
            send(range(len(calls)))
            while futures or waiting:
                if futures:
                    with contextlib.suppress(TimeoutError, concurrent.futures.CancelledError):
                        distributed.wait(list(futures), timeout=STOP_POLL_S, return_when="FIRST_COMPLETED")
                else:  # only calls waiting for the scheduler to come back
                    time.sleep(STOP_POLL_S)
                stop_if_asked()
                self._check(watch, [*futures.values(), *waiting])
                for future in [f for f in futures if f.done()]:
                    i = futures.pop(future)
                    if not future.cancelled():
                        _hand_back(future, i, on_result, on_lost)
                    elif resent[i] < MAX_RESENDS:
                        resent[i] += 1
                        waiting.append(i)
                    else:
                        _lost(i, f"its workers died with the run's shared data {MAX_RESENDS + 1} times", on_lost)
                if waiting and self.client.status == "running" and not watch.seconds_without_workers():
                    # Scattering waits for a worker, then gives up: the calls wait for the next round (or the watch).
                    with contextlib.suppress(TimeoutError):
                        send(waiting)
                        waiting = []
        except BaseException as exc:
            missing = sorted([*futures.values(), *waiting])
            if self._lost_scheduler() and not isinstance(exc, ClusterLost):
                raise self._scheduler_lost(missing) from None
            with contextlib.suppress(Exception):  # a client that lost its scheduler cannot cancel
                self.client.cancel(list(futures))
            raise
        finally:
            with contextlib.suppress(Exception):
                self.client.cancel(scattered)

    def _check(self, watch: _WorkerWatch, pending: list[int]) -> None:
        """Raise `ClusterLost` when the scheduler is gone for good, or no worker has been seen for `NO_WORKERS_S`."""
        if self._lost_scheduler():
            raise self._scheduler_lost(pending)
        if (gone := watch.seconds_without_workers()) >= NO_WORKERS_S:
            raise ClusterLost(f"{self.address}: no worker in the cluster for {gone:.0f} s (none joined, or each died or left); "
                              f"{len(pending)} calls not done", tuple(sorted(pending)))

    def _lost_scheduler(self) -> bool:
        # "connecting": the client tries again for its timeout, then closes; anything but that or running is the end.
        return self.client.status not in ("running", "connecting")

    def _scheduler_lost(self, pending: Sequence[int]) -> ClusterLost:
        return ClusterLost(f"{self.address}: the Dask scheduler stopped answering and did not come back within "
                           f"{CONNECT_TIMEOUT_S:g} s; {len(pending)} calls not done", tuple(sorted(pending)))

    def close(self) -> None:
        """Close the client, and the cluster where this process started it."""
        self.client.close()
        # A client that closed itself (its scheduler lost for good) returns from close() at once and leaves its
        # event loop's thread running: stopped here, so no thread outlives the run (stopping twice does nothing).
        self.client._loop_runner.stop()
        self.quiet.close()
        if self.cluster is not None:
            self.cluster.close()


class _WorkerWatch:
    """How long a cluster has been without a worker, asking its scheduler at most every `WORKER_CHECK_S`."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.asked = -WORKER_CHECK_S
        self.without_since: float | None = None

    def seconds_without_workers(self) -> float:
        now = time.monotonic()
        if self.client.status == "running" and now - self.asked >= WORKER_CHECK_S:
            self.asked = now
            workers = self.client.scheduler_info(n_workers=0).get("n_workers", 1)
            self.without_since = None if workers else now if self.without_since is None else self.without_since
        return 0.0 if self.without_since is None else now - self.without_since


def _hand_back(future: Any, i: int, on_result: Callable[[int, Any], None],
               on_lost: Callable[[int, str], None] | None) -> None:
    """The result of a finished Dask future to `on_result`; a call lost with its workers to `on_lost`."""
    from distributed import KilledWorker

    if future.status != "error":
        on_result(i, future.result())
        return
    error = future.exception()
    if not isinstance(error, KilledWorker):
        raise error
    _lost(i, f"its worker died and the cluster gave up rerunning it ({error})", on_lost)


def _lost(i: int, reason: str, on_lost: Callable[[int, str], None] | None) -> None:
    if on_lost is None:
        raise LostCall(reason)
    on_lost(i, reason)


def scheduler(address: str | None, *, workers: int | None = None) -> Executor:
    """The executor for `address`: None, this machine's pool of `workers`; ``local:N``, a Dask LocalCluster
    of N processes; else a Dask scheduler's address (``tcp://HOST:8786``).

    Raises `SchedulerError` (address and reason) when Dask is missing, the form is unknown, or the scheduler
    does not answer within `CONNECT_TIMEOUT_S`."""
    if address is None:
        return LocalPool(workers)
    try:
        import distributed
    except ImportError:
        raise SchedulerError(f"{address}: Dask is not installed; install careful[cluster]") from None
    if match := LOCAL.fullmatch(address):
        n = int(match.group(1))
        if not 1 <= n <= MAX_LOCAL_WORKERS:
            raise SchedulerError(f"{address}: a local cluster needs 1 to {MAX_LOCAL_WORKERS} workers, not {n}")
        # On this machine only, and its status page on a free port (8787 may be another cluster's).
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                           dashboard_address="127.0.0.1:0", silence_logs=50)
        return DaskExecutor(distributed.Client(cluster), cluster=cluster, address=address)
    if "://" not in address:
        raise SchedulerError(f"{address}: not local:N nor a scheduler address such as tcp://HOST:8786")
    _listening(address)
    # Dask's own log lines ("Failed to reconnect to scheduler ...") would come beside careful's one line on stderr;
    # silenced while the client lives, as a local cluster's are (`silence_logs`): what went wrong is said once.
    quiet = contextlib.ExitStack()
    quiet.enter_context(distributed.utils.silence_logging_cmgr(logging.CRITICAL))
    try:
        client = _connected(distributed, address)
    except BaseException:
        quiet.close()
        raise
    return DaskExecutor(client, address=address, quiet=quiet)


def _connected(distributed: Any, address: str) -> Any:
    """`_client`, its failures as `SchedulerError`."""
    try:
        return _client(distributed, address)
    except TimeoutError:
        raise SchedulerError(f"{address}: what accepted the connection did not answer as a Dask scheduler within "
                             f"{CONNECT_TIMEOUT_S:g} s (not a Dask scheduler, or one too busy to answer)") from None
    except OSError as exc:
        raise SchedulerError(f"{address}: no Dask scheduler answered ({_first_line(exc)})") from None
    except Exception as exc:  # noqa: BLE001 - whatever answered there is not a Dask scheduler, a user's error
        raise SchedulerError(f"{address}: what answered is not a Dask scheduler ({_first_line(exc)})") from None


def _client(distributed: Any, address: str) -> Any:
    """A Dask client of the scheduler at `address`, connected and through the handshake within `CONNECT_TIMEOUT_S`,
    else `TimeoutError` (and the client closed). Dask bounds the connection but not the handshake's first read: a
    listener that accepts and never speaks would hold the client for ever."""

    class BoundedClient(distributed.Client):
        def start(self, **kwargs: Any) -> None:
            try:
                super().start(callback_timeout=CONNECT_TIMEOUT_S, **kwargs)
            except BaseException:
                self.close()
                raise

    return BoundedClient(address, timeout=CONNECT_TIMEOUT_S)


def _listening(address: str) -> None:
    """Raise `SchedulerError` when nothing listens at a tcp:// address. Asked with a plain socket first: a Dask
    client that cannot connect leaves its event loop's thread running in this process."""
    match = re.fullmatch(r"tcp://\[?([^\]]+?)\]?:(\d+)/?", address)
    if match is None:
        return
    try:
        socket.create_connection((match.group(1), int(match.group(2))), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise SchedulerError(f"{address}: no Dask scheduler answered ({_first_line(exc)})") from None


def _first_line(error: BaseException) -> str:
    text = str(error).strip()
    return f"{type(error).__name__}: {text.splitlines()[0][:200]}" if text else type(error).__name__


def close(executor: Executor) -> None:
    """Close what `scheduler` opened (nothing for a local pool)."""
    if isinstance(executor, DaskExecutor):
        executor.close()
