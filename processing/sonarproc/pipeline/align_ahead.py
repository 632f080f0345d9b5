"""The align stage of a run (:func:`align_stage`), on the second core while the run maps
the log as it was read (:class:`AlignAhead`).

The align stage (:func:`sonarproc.pipeline.alignment.align_log`) decides whether a log's
poses are corrected for odometry drift. Most logs keep their poses: a log whose echoes
do not show drift significantly is returned as it is, the very object (its results do
not move). So the run need not wait for the decision to map: :meth:`AlignAhead.start`
forks a child (:class:`sonarproc.forked.ForkedChild`) that aligns, while this process
selects the readings, lays the grid and builds the map from the poses as read. As the
map is built, before its fit, :meth:`AlignAhead.result` collects the decision: a log kept
as it is keeps that map; a corrected log is mapped again from its corrected poses (the
first map is dropped). Either way the result is the one the stages give one after the
other (tested): the child runs the same code on the same readings.

Where no child may be forked (:func:`~sonarproc.forked.fork_is_safe`: Linux, two cores,
one thread, no pool) or the child fails, the stage runs here, first, as before.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

from sonarlog import SonarLog
from sonarproc.forked import AheadJob, fork_is_safe

if TYPE_CHECKING:
    from sonarproc.pipeline.alignment import AlignmentRecord

__all__ = ["AlignAhead", "Aligned", "align_stage"]

Progress = Callable[[str], None]


class Aligned(NamedTuple):
    """A log after the align stage: its poses, what the stage decided, and what it cost."""

    log: SonarLog
    record: AlignmentRecord
    wall_s: float
    cpu_s: float


def align_stage(log_: SonarLog, progress: Progress | None = None) -> Aligned:
    """The align stage of a run (:func:`sonarproc.pipeline.alignment.align_log`), timed.

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The readings as logged.
    progress : callable, optional
        Called with ``"align"`` as the stage starts.

    Returns
    -------
    Aligned
        The log with its poses aligned where that helps, the record of why, and the
        stage's wall and CPU seconds.
    """
    from sonarproc.pipeline.alignment import align_log

    if progress is not None:
        progress("align")
    t0, c0 = time.perf_counter(), time.process_time()
    aligned, record = align_log(log_)
    return Aligned(aligned, record, time.perf_counter() - t0, time.process_time() - c0)


class AlignAhead(AheadJob):
    """The align stage of one log, run in a forked child or, failing that, here.

    While a child aligns (:attr:`forked`) the log may be mapped meanwhile.

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The readings as logged.
    """

    def __init__(self, log_: SonarLog) -> None:
        super().__init__()
        self.log = log_
        self._done: Aligned | None = None
        self.here = False  # whether the stage ran in this process (its CPU time is ours)

    @classmethod
    def start(cls, log_: SonarLog, progress: Progress | None = None) -> AlignAhead:
        """The align stage of ``log_``, its child forked now where that is safe.

        ``progress`` is called with ``"align"`` as the stage starts.
        """
        if progress is not None:
            progress("align")
        job = cls(log_)
        if fork_is_safe():
            job.fork(job._in_child)
        return job

    def _in_child(self) -> tuple[SonarLog | None, AlignmentRecord, float, float]:
        """In the child: the stage's answer, with no log when the log is kept as it is
        (the parent has it: the same object, not a copy of it)."""
        got = align_stage(self.log)
        return (None if got.log is self.log else got.log), got.record, got.wall_s, got.cpu_s

    def result(self) -> Aligned:
        """The stage's answer: the child's, or computed here (no child, or it failed)."""
        if self._done is None:
            got: Any = self.collect()
            if isinstance(got, tuple) and len(got) == 4:
                log_, record, wall_s, cpu_s = got
                self._done = Aligned(self.log if log_ is None else log_, record, wall_s, cpu_s)
            else:
                self.here = True
                self._done = align_stage(self.log)
        return self._done
