"""``sonarproc watch --foxglove``: follow a growing log and publish it to Foxglove live.

Every :data:`POLL_S` the rows appended since the last poll are read (:class:`LogTail`)
and published at once (beams, raw rows, pose, path, transforms), and rasterised onto the
live count map (:class:`~sonarproc.pipeline.live.LiveAccumulator`). The map, the
surfaces and the quality figures are redone by a snapshot, which costs time in
proportion to the map, not to the new readings; :class:`~sonarproc.live.pacing.SnapshotPacer`
decides when: within the latency promise of the oldest reading not yet mapped, within a
CPU budget. A snapshot publishes only what changed
(:class:`~sonarproc.live.map_messages.MapPublisher`).

The report directory is written once, when the watch ends (a live viewer replaces the
report page's reloads).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.errors import SonarprocError
from sonarproc.live.pacing import (
    LATENCY_PROMISE_S,
    MAX_SNAPSHOT_DUTY,
    MIN_SNAPSHOT_GAP_S,
    POLL_S,
    SNAPSHOT_DUTY,
    SnapshotPacer,
)
from sonarproc.live.session import LiveServer
from sonarproc.live.tail import LogTail
from sonarproc.params import RunParams
from sonarproc.pipeline.live import LiveAccumulator
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.watch import WatchOutcome

__all__ = [
    "LATENCY_PROMISE_S",
    "MAX_SNAPSHOT_DUTY",
    "MIN_SNAPSHOT_GAP_S",
    "POLL_S",
    "SNAPSHOT_DUTY",
    "follow_live",
    "live_watch",
]

log = logging.getLogger(__name__)

#: Readings published per batch when catching up on a log that already holds many.
CATCH_UP_BATCH = 500


def follow_live(
    log_path: Path,
    params: RunParams,
    host: str,
    port: int,
    *,
    out_dir: Path | None = None,
    idle: float = 10.0,
    once: bool = False,
    truth: Path | None = None,
    stop: threading.Event | None = None,
    on_listen: Callable[[str, int], None] | None = None,
    status: Callable[[str], None] | None = None,
    figures: Sequence[str] = ("png", "svg"),
) -> WatchOutcome:
    """Follow ``log_path`` and serve it to Foxglove at ``host:port`` until told to stop.

    Parameters
    ----------
    log_path : Path
        The sonarlog being written (``.h5``).
    params : RunParams
        Processing parameters (as ``sonarproc run``).
    host, port : str, int
        Where to listen; port 0 picks a free port (passed to ``on_listen``).
    out_dir : Path, optional
        Where to write the final report.
    idle : float
        Once the writer has closed the log, stop after this many seconds without new
        readings.
    once : bool
        Publish the log as it is now, one snapshot, then stop.
    truth : Path, optional
        A truth CSV replacing the log's ``/truth/profile``.
    stop : threading.Event, optional
        Set it to stop.
    on_listen : callable, optional
        Called with ``(host, port)`` once the server listens.
    status : callable, optional
        Called with a one-line summary after each snapshot.
    figures : sequence of str
        The figure formats of the report written when the watch ends (``()`` for none).

    Returns
    -------
    WatchOutcome

    Raises
    ------
    sonarlog.SonarLogError, OSError
        The log cannot be read, or the port cannot be bound.
    """
    # the fit's modules (scipy's graphs and trees, 1-2 s to import on a busy host) are
    # imported lazily by a run; here the first map update would pay for them, late for the
    # readings waiting on it, and its cost would space the next updates as if it were theirs
    import sonarproc.pipeline.surfacefit  # noqa: F401
    from sonarlog import SonarLogError, read_log, writer_closed
    from sonarlog.csvlog import read_truth_csv

    stop = stop or threading.Event()
    first = None
    if _recorded(log_path):  # a bag, CSV or Player log: no writer appends to it
        from sonarproc.pipeline import load_log

        first = load_log(log_path)
    while first is None:
        try:
            first = read_log(log_path)
        except (SonarLogError, OSError):
            if not log_path.exists() or writer_closed(log_path) or once or stop.is_set():
                raise
            stop.wait(POLL_S)
    if truth is not None:
        first = replace(first, truth=read_truth_csv(truth))
    server = LiveServer(host, port, sensors=first.sensors, speed_of_sound=first.speed_of_sound)
    try:
        if on_listen is not None:
            on_listen(host, server.port)
        return _serve(log_path, first, params, server, out_dir, idle, once, stop, status, figures)
    finally:
        server.close()


def _serve(
    log_path: Path,
    first: Any,
    params: RunParams,
    server: LiveServer,
    out_dir: Path | None,
    idle: float,
    once: bool,
    stop: threading.Event,
    status: Callable[[str], None] | None,
    figures: Sequence[str],
) -> WatchOutcome:
    from sonarlog import writer_closed

    acc = LiveAccumulator(first, params)
    tail = LogTail(log_path, start=len(first.readings))
    recorded = _recorded(log_path)
    pacer = SnapshotPacer()
    if _take(server, acc, first.readings):
        pacer.taken(time.monotonic())
    result: RunResult | None = None
    updates = 0
    last_new = time.monotonic()
    reason = "once"
    try:
        while True:
            closed = recorded or writer_closed(log_path)
            if not once and not recorded:
                try:
                    new = tail.new_rows()
                except OSError as err:  # a write in flight; try again at the next poll
                    log.debug("%s", err)
                    new = first.readings[:0]
                if _take(server, acc, new):
                    last_new = time.monotonic()
                    pacer.taken(last_new)
            server.catch_up()
            final = once or stop.is_set() or (closed and time.monotonic() - last_new >= idle)
            if pacer.pending and (final or pacer.due(time.monotonic())):
                cpu0, start = time.process_time(), time.monotonic()
                snap = _snapshot(server, acc)
                pacer.done(start, time.monotonic(), time.process_time() - cpu0)
                if snap is not None:
                    result, updates = snap, updates + 1
                    if status is not None:
                        status(f"update {updates}: {acc.n_readings} readings, {_summary(snap)}")
            if final:
                reason = "once" if once else ("signal" if stop.is_set() else "closed")
                break
            stop.wait(pacer.next_check_s(time.monotonic()))
    finally:
        tail.close()
    doc = None
    if result is not None and out_dir is not None:
        from sonarproc.report.atomic import write_report_atomic

        live = {"updates": updates, "readings_seen": acc.n_readings, "final": True}
        doc = write_report_atomic(result, out_dir, live=live, refresh_s=None, figures=figures)
    return WatchOutcome(reason, updates, acc.n_readings, doc)


def _recorded(path: Path) -> bool:
    """Whether ``path`` is a recording no writer appends to (not a sonarlog ``.h5``)."""
    return path.is_dir() or path.suffix.lower() not in (".h5", ".hdf5")


def _take(server: LiveServer, acc: LiveAccumulator, rows: np.ndarray) -> bool:
    """Publish and accumulate ``rows``; whether any arrived."""
    for start in range(0, len(rows), CATCH_UP_BATCH):
        batch = rows[start : start + CATCH_UP_BATCH]
        server.readings(batch)
        try:
            acc.add(batch)
        except ValueError as err:  # a bad row: it is published, not mapped
            log.warning("readings not mapped: %s", err)
    return len(rows) > 0


def _snapshot(server: LiveServer, acc: LiveAccumulator) -> RunResult | None:
    wall0 = time.monotonic()
    try:
        result = acc.snapshot()
    except (SonarprocError, ValueError) as err:  # nothing to map yet, or a bad bbox
        log.info("no map yet: %s", err)
        return None
    if result is None:
        return None
    t_last = float(acc.readings["t"][-1]) if acc.n_readings else math.nan
    server.result(
        result,
        t=time.time(),
        readings=acc.n_readings,
        last_reading_t=t_last,
        update_s=time.monotonic() - wall0,
    )
    return result


def _summary(result: RunResult) -> str:
    n = len(result.surfaces.surfaces) if result.surfaces is not None else 0
    return f"{n} surface(s), {result.counts.get('processed_cells', 0)} processed cells"


def live_watch(
    host: str, port: int, *, on_listen: Callable[[str, int], None] | None = None
) -> Callable[..., WatchOutcome]:
    """A stand-in for :func:`sonarproc.pipeline.watch.watch` that serves Foxglove instead.

    It takes the same arguments (``interval`` and options only the report loop knows are
    ignored: the live loop paces itself) and calls :func:`follow_live`.
    """

    def run(
        log_path: Path,
        params: RunParams,
        out_dir: Path,
        *,
        idle: float = 10.0,
        once: bool = False,
        truth: Path | None = None,
        stop: threading.Event | None = None,
        status: Callable[[str], None] | None = None,
        figures: Sequence[str] = ("png", "svg"),
        **_report_options: Any,
    ) -> WatchOutcome:
        return follow_live(
            log_path, params, host, port, out_dir=out_dir, idle=idle, once=once,
            truth=truth, stop=stop, on_listen=on_listen, status=status, figures=figures,
        )  # fmt: skip

    return run
