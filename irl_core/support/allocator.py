"""Keep the memory a fit frees for its next arrays, where the C allocator is glibc's.

A fit's likelihood makes a few dozen arrays of a few hundred kilobytes each time it is evaluated, and a
people fit evaluates it thousands of times. glibc's malloc gives such blocks back to the kernel once they
are freed (blocks over its mmap threshold, which starts at 128 kB, and free memory at the heap's top over
its trim threshold), so the next array of that size has its pages faulted in and zeroed again: a quarter
of the people fit's CPU time on a 24x24 world (bench_people_big: 6.2-6.8 s and 11 s of CPU with glibc's
defaults, 4.6-5.1 s and 8.3-9.1 s with the settings below; the same answers, to the last digit).

`keep_freed_memory` sets both thresholds once per process (`careful fit` and the pool's workers call it):
blocks up to `MMAP_THRESHOLD` come from the heap, and the heap keeps up to `TRIM_THRESHOLD` free at its
top. The price is that a process may hold that much freed memory instead of returning it (a 64x64 world's
fit frees tens of megabytes per evaluation). Elsewhere (macOS, musl) it does nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import sys

# mallopt's parameter numbers (glibc's malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
# glibc's largest mmap threshold on 64-bit systems (a 64x64 world's (S, A) array is 1.8 MB).
MMAP_THRESHOLD = 32 * 2**20
# Well over what one evaluation of a 64x64 world frees at once (some tens of its 1.8 MB arrays).
TRIM_THRESHOLD = 256 * 2**20

_kept: bool | None = None


def keep_freed_memory() -> bool:
    """Set glibc's thresholds (once per process); True where they are set."""
    global _kept
    if _kept is None:
        _kept = False
        if sys.platform.startswith("linux"):
            with contextlib.suppress(OSError, AttributeError):
                libc = ctypes.CDLL(ctypes.util.find_library("c") or None)
                libc.gnu_get_libc_version  # noqa: B018 (glibc only: musl has mallopt but not these settings)
                _kept = bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
                    libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    return _kept
