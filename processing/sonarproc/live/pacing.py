"""When the live view redoes its map: within the latency promise, within a CPU budget.

A snapshot (morphology, fit and metrics on the whole count map) costs time in proportion
to the map, not to the readings that arrived since the last one, so it cannot run on every
poll. :class:`SnapshotPacer` decides when the next one is due:

* **Relaxed pace.** After a snapshot that cost ``c`` seconds of CPU, the next one waits
  ``c / SNAPSHOT_DUTY`` (and at least :data:`MIN_SNAPSHOT_GAP_S`): snapshots alone then use
  at most :data:`SNAPSHOT_DUTY` of one core.
* **Deadline.** A reading must reach the map within :data:`LATENCY_PROMISE_S` of being
  published. So a snapshot starts early once the oldest reading not yet mapped has waited
  the promise less the time the snapshot itself is expected to take (the longest wall time
  of the last few, which includes what a loaded host stretches it by) and less one poll
  (the loop notices the deadline at its next poll at the latest).
* **CPU ceiling.** Even early, a snapshot starts at least ``c / MAX_SNAPSHOT_DUTY`` after
  the previous one ended, so snapshots never use more than
  ``MAX_SNAPSHOT_DUTY / (1 + MAX_SNAPSHOT_DUTY)`` of one core (a third). While readings
  stream continuously, the first one after a snapshot is published within a poll of its
  end, so a snapshot starts every ``LATENCY_PROMISE_S - POLL_S`` or a little more, and
  snapshots use about ``max(SNAPSHOT_DUTY, c / (LATENCY_PROMISE_S - POLL_S))`` of one core
  up to that ceiling: 17 % for a 0.3 s snapshot. The promise holds while the ceiling's gap
  fits before the deadline, ``w + c / MAX_SNAPSHOT_DUTY <= LATENCY_PROMISE_S - POLL_S``
  (``w`` its wall time: a snapshot of up to about 0.6 s on an idle host). Beyond that the
  map lags by the ceiling's gap plus the snapshot rather than taking the host's CPUs.

The pacer only does arithmetic on the times it is given (monotonic seconds), so its
decisions are tested without a clock.
"""

from __future__ import annotations

from collections import deque

__all__ = [
    "LATENCY_PROMISE_S",
    "MAX_SNAPSHOT_DUTY",
    "MIN_SNAPSHOT_GAP_S",
    "POLL_S",
    "SNAPSHOT_DUTY",
    "SnapshotPacer",
]

#: Seconds between reads of the log: sonard makes readings visible every 0.25 s
#: (its flush interval), so polling faster only finds nothing.
POLL_S = 0.2
#: The live view's promise: a reading is on the published map within this many seconds of
#: being published itself (a viewer following a robot sees the map keep up with the beams).
LATENCY_PROMISE_S = 2.0
#: Share of one core the snapshots use when no reading is close to its deadline; reading
#: and publishing the readings themselves take a few per cent more at 25 readings/s.
SNAPSHOT_DUTY = 0.12
#: The gap after a snapshot is at least its CPU time over this, even when a deadline makes
#: the next run early: snapshots then use at most a third of one core, which leaves the
#: rest of it, and the host's other cores, to the robot's own programs.
MAX_SNAPSHOT_DUTY = 0.5
#: Shortest gap between snapshots (s): a viewer sees no difference in faster map updates.
MIN_SNAPSHOT_GAP_S = 0.5
#: How many recent snapshots' wall times predict the next one's: a few, so that one slow
#: snapshot (a burst of load on the host) keeps the next deadlines early for a while.
WALL_HISTORY = 4


class SnapshotPacer:
    """Decide when the live view's next snapshot is due.

    Parameters
    ----------
    promise_s : float
        Latency promise (s): a published reading is mapped within it.
    duty, max_duty : float
        Share of one core snapshots use at the relaxed pace, and at most (0 < duty <=
        max_duty <= 1).
    min_gap_s : float
        Shortest gap between the end of one snapshot and the start of the next (s).
    poll_s : float
        How often the caller asks :meth:`due` (s).

    Raises
    ------
    ValueError
        A duty outside (0, 1], ``duty > max_duty``, or a negative time.
    """

    def __init__(
        self,
        *,
        promise_s: float = LATENCY_PROMISE_S,
        duty: float = SNAPSHOT_DUTY,
        max_duty: float = MAX_SNAPSHOT_DUTY,
        min_gap_s: float = MIN_SNAPSHOT_GAP_S,
        poll_s: float = POLL_S,
    ) -> None:
        if not 0 < duty <= max_duty <= 1:
            raise ValueError(f"duty: need 0 < duty <= max_duty <= 1, got {duty}, {max_duty}")
        if min(promise_s, min_gap_s, poll_s) < 0:
            raise ValueError("promise_s, min_gap_s, poll_s: must be >= 0")
        self.promise_s = promise_s
        self.duty = duty
        self.max_duty = max_duty
        self.min_gap_s = min_gap_s
        self.poll_s = poll_s
        self._oldest: float | None = None
        self._last_end = -float("inf")
        self._cpu = 0.0
        self._walls: deque[float] = deque(maxlen=WALL_HISTORY)

    @property
    def pending(self) -> bool:
        """Whether a reading has arrived since the last snapshot."""
        return self._oldest is not None

    def taken(self, now: float) -> None:
        """Readings were published at ``now``; the first since the last snapshot sets the
        deadline."""
        if self._oldest is None:
            self._oldest = now

    def expected_wall_s(self) -> float:
        """The wall time the next snapshot is expected to take (s): the longest of the last
        few, 0 before the first."""
        return max(self._walls, default=0.0)

    def deadline(self) -> float:
        """When the next snapshot must start for the oldest unmapped reading to keep the
        promise (monotonic s); +inf with nothing pending."""
        if self._oldest is None:
            return float("inf")
        return self._oldest + self.promise_s - self.poll_s - self.expected_wall_s()

    def due(self, now: float) -> bool:
        """Whether a snapshot should start at ``now``."""
        if self._oldest is None:
            return False
        since = now - self._last_end
        if since < max(self.min_gap_s, self._cpu / self.max_duty):
            return False  # the CPU ceiling
        if since >= max(self.min_gap_s, self._cpu / self.duty):
            return True  # the relaxed pace
        return now >= self.deadline()

    def next_check_s(self, now: float) -> float:
        """How long the caller may sleep before asking again (s): one poll, or less when a
        deadline falls sooner (never below 0)."""
        if self._oldest is None:
            return self.poll_s
        earliest = self._last_end + max(self.min_gap_s, self._cpu / self.max_duty)
        return max(0.0, min(self.poll_s, max(self.deadline(), earliest) - now))

    def done(self, start: float, end: float, cpu_s: float) -> None:
        """A snapshot started at ``start`` and ended at ``end`` (monotonic s), using
        ``cpu_s`` of CPU: everything published before ``start`` is mapped."""
        self._oldest = None
        self._last_end = end
        self._cpu = max(0.0, cpu_s)
        self._walls.append(max(0.0, end - start))
