"""Work done on the second core by a forked child: when a fork is safe, and the child.

A run hands work that needs nothing the run computes later to a child forked for it: the
report's figures (:mod:`sonarproc.report.ahead`, :mod:`sonarproc.report.drawing`) and the
held-out refit of the quality stage (:mod:`sonarproc.quality.ahead`). A fork inherits
the arrays as they are (copy on write: nothing is pickled but the answer that comes
back), and is taken only where it is safe and gains something (:func:`fork_is_safe`).
The caller always keeps a way to do the work itself: a child that cannot be forked or
fails gives None, never a different answer. :class:`AheadJob` is the bookkeeping of such
work for a caller that collects one answer later: the child started, collected once, or
stopped when its answer is no longer wanted.
"""

from __future__ import annotations

import gc
import logging
import os
import pickle
import sys
import threading
from collections.abc import Callable
from typing import Any

__all__ = ["AheadJob", "ForkedChild", "fork_is_safe"]

log = logging.getLogger(__name__)


def fork_is_safe() -> bool:
    """Whether work may go to a forked child: two cores to work on, not already shared
    with the sibling workers of a pool (this is no pool's worker), and a fork is safe
    (Linux, no other thread: a lone thread holds no lock the child could inherit locked)."""
    import multiprocessing

    if sys.platform != "linux" or not hasattr(os, "fork"):
        return False
    if multiprocessing.parent_process() is not None:
        return False
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    return cores >= 2 and threading.active_count() == 1


class ForkedChild:
    """A forked child computing one picklable answer; :meth:`collect` reads it."""

    def __init__(self, pid: int, fd: int) -> None:
        self.pid, self.fd = pid, fd

    @classmethod
    def start_work(cls, work: Callable[[], Any]) -> ForkedChild | None:
        """Fork a child that sends back what ``work()`` returns (None: no child)."""
        read_fd, write_fd = os.pipe()
        try:
            pid = os.fork()
        except OSError as err:  # no memory or process left: the caller does the work
            log.debug("no child forked (%s)", err)
            os.close(read_fd)
            os.close(write_fd)
            return None
        if pid == 0:  # the child: work, send, and leave without running any exit handler
            _child_main(work, read_fd, write_fd)
        os.close(write_fd)
        return cls(pid, read_fd)

    def collect_any(self) -> Any | None:
        """The child's answer, unpickled; None if it failed (the caller does the work)."""
        with os.fdopen(self.fd, "rb") as pipe:
            payload = pipe.read()
        _, status = os.waitpid(self.pid, 0)
        if status != 0 or not payload:
            log.debug("the child %d failed (status %d)", self.pid, status)
            return None
        return pickle.loads(payload)  # our own child's answer

    def cancel(self) -> None:
        """Stop the child (its answer is no longer wanted) and reap it."""
        import signal
        from contextlib import suppress

        with suppress(ProcessLookupError):  # it has exited: it is reaped below all the same
            os.kill(self.pid, signal.SIGKILL)
        os.close(self.fd)
        os.waitpid(self.pid, 0)


class AheadJob:
    """Work handed to a forked child now and collected once later, or done by the caller.

    A subclass holds the work's inputs and starts the child where a fork is safe
    (``if fork_is_safe(): job.fork(work)``); as it needs the answer it calls
    :meth:`collect` and, given None (no child, or it failed), does the work itself.
    """

    def __init__(self) -> None:
        self._child: ForkedChild | None = None

    def fork(self, work: Callable[[], Any]) -> None:
        """Hand ``work`` to a forked child (none when no child can be forked)."""
        self._child = ForkedChild.start_work(work)

    @property
    def forked(self) -> bool:
        """Whether a child works on the answer (not yet collected)."""
        return self._child is not None

    def collect(self) -> Any | None:
        """The child's answer; None if there is no child or it failed. Asked once."""
        child, self._child = self._child, None
        return child.collect_any() if child is not None else None

    def cancel(self) -> None:
        """Stop the child, if it still runs: its answer is not wanted."""
        child, self._child = self._child, None
        if child is not None:
            child.cancel()


def _child_main(work: Callable[[], Any], read_fd: int, write_fd: int) -> None:
    code = 1
    try:
        # what the child inherits outlives it: its collections never look at it (nor
        # write to its pages, which the parent's memory shares until written)
        gc.freeze()
        os.close(read_fd)
        payload = pickle.dumps(work(), protocol=pickle.HIGHEST_PROTOCOL)
        with os.fdopen(write_fd, "wb") as pipe:
            pipe.write(payload)
        code = 0
    finally:
        os._exit(code)
