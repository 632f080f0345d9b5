"""Process-wide settings the ``sonarproc`` command makes before it works.

:func:`retain_freed_memory`: a map of a room at 1 cm is four million cells, and a run
allocates and frees arrays of tens of megabytes by the dozen (counts, masks, each arc's
cells). glibc's malloc serves blocks that large with fresh ``mmap`` pages and hands them
back to the kernel on ``free``, so every one of them is page-faulted in again, zeroed by
the kernel: on the 90 000-reading room log that was a third of ``--auto``'s time, in the
kernel. Serving them from the heap and keeping what is freed for the next array (up to
the limits below) removes it. The command line sets this; the library does not touch a
host process's allocator.

:func:`freeze_modules` and :func:`loading_modules`: the console script puts the modules it
has loaded out of the cyclic collector's sight (:func:`gc.freeze`), and a command that
loads its stages' modules later (``run``: scipy's, a few hundred thousand objects) loads
them with the collector off and freezes them too. Otherwise the collections during those
imports, and the first full collection after them (one comes within the run's first
stages), walk every object they made, to free none: a few tens of milliseconds on the
run's critical path. Only the console script turns this on: a host process calling the
command's ``main`` keeps its collector as it is.
"""

from __future__ import annotations

import ctypes
import gc
import sys
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = [
    "HEAP_BLOCK_LIMIT",
    "HEAP_KEEP_LIMIT",
    "freeze_modules",
    "loading_modules",
    "retain_freed_memory",
]

#: Whether :func:`loading_modules` freezes (set by :func:`freeze_modules`).
_freezing = False

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


def freeze_modules() -> None:
    """Freeze what the process holds now, and the modules later loaded in
    :func:`loading_modules` (the console script; see the module notes)."""
    global _freezing
    _freezing = True
    gc.freeze()


@contextmanager
def loading_modules() -> Iterator[None]:
    """Load a command's modules in this block: where the console script asked for it
    (:func:`freeze_modules`), with the collector off (the objects made are modules,
    classes and functions that live as long as the process: a collection among them frees
    nothing) and frozen after it; nothing changes otherwise."""
    if not _freezing:
        yield
        return
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if was_enabled:
            gc.enable()
