"""Keep freed image buffers in the process, so that repeated decodes do not fault memory in again.

A decode of a 2560x2048 capture allocates and frees ~200 MB of maps per call. With glibc's
defaults a freed block above its mmap threshold (128 KiB, raised dynamically to at most
32 MiB) goes back to the kernel, and so does free memory at the top of the heap beyond twice
that threshold; the next call takes the same memory back one page fault at a time (~10,000
faults and ~55 ms of system time per 2560x2048 decode on 2 cores, which made decode() slower
per pixel at large sizes than at 1280x1024). :func:`keep_freed_memory` raises both thresholds
(``mallopt(M_MMAP_THRESHOLD)`` and ``mallopt(M_TRIM_THRESHOLD)``) to :data:`KEEP_BYTES`, so
that the process keeps what it freed and reuses it: the resident size stays at its peak
instead of shrinking between calls. The decoder and the reconstruction engine call it once.

It changes nothing on other C libraries (musl, macOS, Windows) and nothing when the
environment variable ``FRINGE3D_RETURN_FREED_MEMORY`` is ``1`` (for a long-lived process
that must give memory back after a burst of work).
"""
from __future__ import annotations

import ctypes
import functools
import os
import sys

#: Blocks below this size come from the heap, and up to this much free memory stays at its top.
KEEP_BYTES = 1 << 30
#: The environment variable that leaves glibc's defaults alone when set to ``1``.
OPT_OUT_VARIABLE = "FRINGE3D_RETURN_FREED_MEMORY"

_M_TRIM_THRESHOLD = -1  # glibc's <malloc.h>
_M_MMAP_THRESHOLD = -3


def _glibc() -> ctypes.CDLL | None:
    """The running glibc, or None on another C library or platform."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(None)
        version = libc.gnu_get_libc_version
    except (OSError, AttributeError):
        return None
    version.restype = ctypes.c_char_p
    return libc if version() else None


@functools.cache
def keep_freed_memory() -> bool:
    """Make this process keep freed memory for reuse (glibc only; once per process).

    Returns
    -------
    bool
        True when glibc accepted both thresholds (now or at an earlier call), False on
        another C library, when ``FRINGE3D_RETURN_FREED_MEMORY=1``, or when glibc refused.
    """
    libc = None if os.environ.get(OPT_OUT_VARIABLE) == "1" else _glibc()
    return bool(libc is not None and libc.mallopt(_M_MMAP_THRESHOLD, KEEP_BYTES)
                and libc.mallopt(_M_TRIM_THRESHOLD, KEEP_BYTES))
