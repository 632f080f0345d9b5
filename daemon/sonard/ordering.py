"""Hand readings to the log in non-decreasing time order (DESIGN contract: sorted ``t``).

A state reply lists the sonars in mask order, not firing order, and with pose attachments
a firing whose echo was still out at one poll shows up at the next one, with a firing time
before readings already seen. :class:`TimeOrder` therefore holds readings back until no
later reply can bring an earlier one: a firing not reported by a reply at robot time
``T`` finishes its echo window after ``T``, so it fired after ``T - interval``. Readings up
to that watermark (with one more interval of margin) are released, sorted stably by
``t``; the rest wait for the next reply. The delay is two firing intervals (80 ms at the
default 40 ms): well inside the one second a crash may lose.

A reading older than one already released (a clock glitch the plausibility check let
through) cannot be placed any more; it is dropped, counted in :attr:`TimeOrder.late` and
handed to ``on_late`` (the recorder logs the span as a ``gap``: the log must say which
firings it is missing).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from sonarlog import READING_DTYPE

__all__ = ["TimeOrder"]

log = logging.getLogger(__name__)


class TimeOrder:
    """A reorder buffer for readings (:data:`sonarlog.READING_DTYPE`).

    Parameters
    ----------
    hold : float
        How far behind the newest reply's time readings are held (s).
    on_late : callable, optional
        Called with the ``t`` of the readings each push drops as late.

    Examples
    --------
    >>> from sonarlog import empty_readings
    >>> order = TimeOrder(hold=0.1)
    >>> rows = empty_readings(3)
    >>> rows["t"] = [1.00, 0.95, 1.02]
    >>> order.push(rows, now=1.05)["t"].tolist()
    [0.95]
    >>> order.drain()["t"].tolist()
    [1.0, 1.02]
    """

    def __init__(self, hold: float, *, on_late: Callable[[np.ndarray], None] | None = None) -> None:
        self.hold = float(hold)
        self._on_late = on_late
        self._held = np.zeros(0, READING_DTYPE)
        self._last_t = -np.inf
        #: readings dropped because they came after later ones were already released
        self.late = 0

    @property
    def held(self) -> int:
        """Readings waiting for the watermark."""
        return len(self._held)

    def push(self, rows: np.ndarray, now: float) -> np.ndarray:
        """Add ``rows``; return the readings with ``t <= now - hold``, sorted by ``t``.

        Parameters
        ----------
        rows : ndarray
            New readings, any order.
        now : float
            UNIX time of the reply that brought them (robot clock + offset).
        """
        if len(rows):
            late = rows["t"] < self._last_t
            if late.any():
                n = int(late.sum())
                self.late += n
                log.warning("%d reading(s) older than readings already logged dropped", n)
                if self._on_late is not None:
                    self._on_late(np.asarray(rows["t"][late]))
                rows = rows[~late]
            self._held = np.concatenate([self._held, rows.astype(READING_DTYPE, copy=False)])
        if not len(self._held):
            return self._held[:0]
        return self._release(int(np.searchsorted(self._sorted_t(), now - self.hold, side="right")))

    def drain(self) -> np.ndarray:
        """Release everything held (the run is ending), sorted by ``t``."""
        if not len(self._held):
            return self._held[:0]
        self._sorted_t()
        return self._release(len(self._held))

    def _sorted_t(self) -> np.ndarray:
        order = np.argsort(self._held["t"], kind="stable")
        self._held = self._held[order]
        return np.asarray(self._held["t"])

    def _release(self, n: int) -> np.ndarray:
        out, self._held = self._held[:n], self._held[n:]
        if len(out):
            self._last_t = float(out["t"][-1])
        return out
