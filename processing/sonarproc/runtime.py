"""Process-wide settings the ``sonarproc`` command makes before it works.

:func:`retain_freed_memory`: a map of a room at 1 cm is four million cells, and a run
allocates and frees arrays of tens of megabytes by the dozen (counts, masks, each arc's
cells). glibc's malloc serves blocks that large with fresh ``mmap`` pages and hands them
back to the kernel on ``free``, so every one of them is page-faulted in again, zeroed by
the kernel: on the 90 000-reading room log that was a third of ``--auto``'s time, in the
kernel. Serving them from the heap and keeping what is freed for the next array (up to
the limits below) removes it. The command line sets this; the library does not touch a
host process's allocator.
"""

from __future__ import annotations

import ctypes
import sys

__all__ = ["HEAP_BLOCK_LIMIT", "HEAP_KEEP_LIMIT", "retain_freed_memory"]

#: Blocks up to this size (bytes) come from the heap, not from fresh mmap pages.
HEAP_BLOCK_LIMIT = 512 << 20
#: Freed memory up to this much (bytes) stays with the process for reuse.
HEAP_KEEP_LIMIT = 1 << 30

# mallopt(3) parameters
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def retain_freed_memory() -> bool:
    """Make malloc keep large freed blocks for reuse (glibc only; see the module notes).

    Returns
    -------
    bool
        Whether the allocator took the settings (False off Linux or without glibc).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        # the symbols the process has loaded already: the C library the interpreter runs
        # on, whose allocator numpy uses (ctypes.util.find_library would run ldconfig in
        # a subprocess, at every start, for the same answer)
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # musl and others have no mallopt
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, HEAP_BLOCK_LIMIT)) and bool(
        mallopt(_M_TRIM_THRESHOLD, HEAP_KEEP_LIMIT)
    )
