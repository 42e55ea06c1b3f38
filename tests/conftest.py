"""Shared test helpers live beside this file (`tmux_terminal`); pytest puts this folder on sys.path. Here: the
fixture that waits for the threads a Dask client leaves to end."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import pytest

# The longest a closed Dask client's thread may take to end on a loaded machine (a bound on an event, not a wait).
THREAD_END_S = 60


@pytest.fixture(scope="module")
def no_dask_thread_left_behind() -> Iterator[None]:
    """Dask keeps threads after its clients close; a process with a second thread forks its pools from a server
    (`pool.process_context`), which would change how later tests' pools start. Their end is waited for here (each
    thread's own end, up to a bound), never a fixed time."""
    before = set(threading.enumerate())
    yield
    import distributed

    # Dask's one offload thread ends only with its executor: ended, and a new one put in its place (its thread
    # starts at its first use), so that a later test's cluster still has one.
    distributed.utils._offload_executor.shutdown(wait=True)
    distributed.utils._offload_executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="Dask-Offload")
    for thread in set(threading.enumerate()) - before:
        thread.join(timeout=THREAD_END_S)
    assert set(threading.enumerate()) <= before, [thread.name for thread in set(threading.enumerate()) - before]
