"""Independent pieces of ``--auto`` on a few threads.

The folds' maps and fits, the fit to all the scored readings and the echo refit's starts
do not depend on each other. Their work is numpy and scipy array operations, which
release the GIL, so threads overlap them without copying the readings to other
processes; each piece's results are gathered in order, so the outcome does not depend
on the number of threads.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

__all__ = ["MAX_WORKERS", "available_workers", "in_threads"]

T = TypeVar("T")
R = TypeVar("R")

#: At most this many threads: beyond a few, the pieces' Python overhead (under the GIL)
#: and memory bandwidth gain nothing more.
MAX_WORKERS = 4


def available_workers() -> int:
    """The CPUs this process may run on, at most :data:`MAX_WORKERS`."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        n = os.cpu_count() or 1
    return max(1, min(n, MAX_WORKERS))


def in_threads(fn: Callable[[T], R], items: Iterable[T], workers: int | None = None) -> list[R]:
    """``[fn(x) for x in items]``, on up to ``workers`` threads (default: the CPUs).

    Examples
    --------
    >>> in_threads(lambda x: x * x, range(5), workers=2)
    [0, 1, 4, 9, 16]
    """
    todo = list(items)
    n = available_workers() if workers is None else max(1, workers)
    if n == 1 or len(todo) <= 1:
        return [fn(x) for x in todo]
    with ThreadPoolExecutor(max_workers=min(n, len(todo))) as pool:
        return list(pool.map(fn, todo))
