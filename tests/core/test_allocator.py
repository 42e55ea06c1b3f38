"""glibc keeps the memory a fit frees (`irl_core.support.allocator`): a fit's mid-sized arrays come from the
heap, not from fresh pages of the kernel each time (a quarter of the people fit's CPU time on a 24x24 world)."""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import subprocess
import sys
import textwrap

import pytest


def _glibc() -> bool:
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None)
        return hasattr(libc, "gnu_get_libc_version") and hasattr(libc, "mallinfo2")
    except OSError:
        return False


pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux") or not _glibc(), reason="glibc's malloc only")

# In a fresh process, after a small fit when asked: whether an array of `megabytes` gets a mapping of its own
# (glibc's mallinfo2 counts them). Only one process's first probe tells: freeing a mapped block raises glibc's
# threshold to its size.
PROBE = textwrap.dedent("""
    import ctypes, json, sys
    import numpy as np

    class Info(ctypes.Structure):
        _fields_ = [(name, ctypes.c_size_t) for name in
                    "arena ordblks smblks hblks hblkhd usmblks fsmblks uordblks fordblks keepcost".split()]

    libc = ctypes.CDLL(None)
    libc.mallinfo2.restype = Info

    def mapped(megabytes):
        array = np.ones(megabytes * 2**20 // 8)
        with_it = libc.mallinfo2().hblks
        del array
        return with_it - libc.mallinfo2().hblks == 1

    def heap_after_freeing(megabytes):
        array = np.ones(megabytes * 2**20 // 8)
        del array
        return libc.mallinfo2().arena

    from irl_core.irl import fit
    from irl_core.players.experts import demonstrations_of, optimal_policy, rollouts
    from irl_core.worlds.mdp import build_mdp
    from irl_core.worlds.world import load_world
    mdp = build_mdp(load_world("paper"))
    if sys.argv[1] == "fit":
        fit(demonstrations_of(mdp, rollouts(mdp, optimal_policy(mdp), episodes=5, seed=0)), method="lp")
    arena = libc.mallinfo2().arena
    print(json.dumps({"16": mapped(16), "64": mapped(64), "grown": heap_after_freeing(16) - arena}))
""")


def _probe(first: str) -> dict:
    out = subprocess.run([sys.executable, "-c", PROBE, first], capture_output=True, text=True, check=True, timeout=120)
    return json.loads(out.stdout)


def test_after_a_fit_mid_sized_arrays_come_from_the_heap_and_stay_there() -> None:
    assert _probe("nothing")["16"] is True  # glibc's default: its own mapping, given back when freed
    after = _probe("fit")
    assert after["16"] is False  # from the heap
    assert after["64"] is True  # over MMAP_THRESHOLD: still mapped
    assert after["grown"] >= 16 * 2**20  # and the heap keeps the 16 MB once freed
