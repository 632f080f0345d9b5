"""Live processing of a log a writer (``sonard``) is still writing: :func:`watch`.

Every ``interval`` seconds the log is re-read (SWMR; :func:`sonarlog.read_log` opens
files still being written), the readings past the last seen row go to a
:class:`~sonarproc.pipeline.live.LiveAccumulator`, and when any arrived the report
directory is rewritten atomically (:func:`sonarproc.report.atomic.write_report_atomic`).

Stops after a final report when ``stop`` is set, with ``once`` after one pass, or when
the writer has closed the log and no reading arrived for ``idle`` seconds.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sonarproc.errors import NothingToMapError
from sonarproc.params import RunParams
from sonarproc.pipeline.live import LiveAccumulator
from sonarproc.pipeline.run import load_log, process
from sonarproc.report.summary import summary_line

__all__ = ["WatchOutcome", "watch"]

log = logging.getLogger(__name__)


@dataclass
class WatchOutcome:
    """How a watch ended."""

    reason: str  # "signal", "once", "closed"
    updates: int
    readings: int
    report: dict[str, Any] | None


def watch(
    log_path: Path,
    params: RunParams,
    out_dir: Path,
    *,
    interval: float = 2.0,
    idle: float = 10.0,
    once: bool = False,
    truth: Path | None = None,
    stop: threading.Event | None = None,
    status: Callable[[str], None] | None = None,
    figures: Sequence[str] = ("png", "svg"),
) -> WatchOutcome:
    """Follow ``log_path`` and keep ``out_dir`` up to date until told to stop.

    Parameters
    ----------
    log_path : Path
        The sonarlog being written.
    params : RunParams
        Processing parameters.
    out_dir : Path
        Report directory.
    interval : float
        Seconds between polls.
    idle : float
        Once the writer has closed the log, stop after this many seconds without new
        readings.
    once : bool
        One pass, then stop.
    truth : Path, optional
        A truth CSV replacing the log's ``/truth/profile``.
    stop : threading.Event, optional
        Set it to stop (a final report is written first).
    status : callable, optional
        Called with a one-line summary after each update.
    figures : sequence of str
        Figure formats of each update (``png``, ``svg``); empty: no figures.

    Returns
    -------
    WatchOutcome

    Raises
    ------
    sonarlog.SonarLogError, OSError
        The log cannot be read at the start.
    SonarprocError
        Bad readings, or (with ``once``) nothing to map, as ``sonarproc run``.
    """
    from sonarlog import SonarLogError, read_log, writer_closed
    from sonarlog.csvlog import read_truth_csv
    from sonarproc.report.atomic import write_report_atomic

    stop = stop or threading.Event()
    truth_xy = read_truth_csv(truth) if truth is not None else None

    # A bag or a Player log is never being written by sonard: read it whole, once closed.
    recorded = log_path.is_dir() or log_path.suffix.lower() not in (".h5", ".hdf5")

    def is_closed() -> bool:
        return recorded or writer_closed(log_path)

    def read() -> Any:
        lg = load_log(log_path) if recorded else read_log(log_path)
        return lg if truth_xy is None else replace(lg, truth=truth_xy)

    first = None
    while first is None:
        try:
            first = read()
        except (SonarLogError, OSError):
            # A log its writer has only just created may not be readable yet: wait for
            # it while the writer holds it open (or until told to stop).
            if not log_path.exists() or is_closed() or once or stop.is_set():
                raise
            stop.wait(min(interval, 0.5))
    acc = LiveAccumulator(first, params)
    seen = 0
    updates = 0
    last_new = time.monotonic()
    doc: dict[str, Any] | None = None
    lg = first
    reason = "once"
    while True:
        closed = is_closed()
        if seen:  # the first pass uses the first read
            try:
                lg = read()
            except (SonarLogError, OSError) as err:  # a write in flight; try again later
                log.warning("%s: re-read failed (%s); retrying", log_path, err)
                lg = None
        new = lg.readings[seen:] if lg is not None else None
        final = once or stop.is_set()
        if new is not None and len(new):
            acc.add(new)
            seen += len(new)
            last_new = time.monotonic()
        idle_done = closed and time.monotonic() - last_new >= idle
        final = final or idle_done
        if (new is not None and len(new)) or (final and doc is not None):
            try:
                result = acc.snapshot()
            except NothingToMapError as err:
                if final:
                    raise
                log.warning("%s: nothing to report yet (%s)", log_path, err)
                result = None
            if result is not None:
                updates += 1
                live = {
                    "updates": updates,
                    "readings_seen": seen,
                    "writer_closed": closed,
                    "final": final,
                }
                doc = write_report_atomic(
                    result, out_dir, live=live, refresh_s=None if final else interval,
                    figures=figures,
                )  # fmt: skip
                if status is not None:
                    status(f"update {updates}: {seen} readings, {summary_line(doc)}")
        if final:
            if once and doc is None:
                # nothing to report: fail the way ``sonarproc run`` does on this log
                process(lg if lg is not None else first, params)
            reason = "once" if once else ("signal" if stop.is_set() else "closed")
            break
        stop.wait(interval)
        if stop.is_set():
            continue  # one more pass: pick up the last readings, write the final report
    return WatchOutcome(reason, updates, seen, doc)
