"""``sonarproc watch``: live processing of a log a writer (``sonard``) is still writing.

Every ``--interval`` seconds the log is re-read (SWMR; :func:`sonarlog.read_log` opens
files still being written), the readings past the last seen row go to a
:class:`~sonarproc.live.LiveAccumulator`, and when any arrived the report directory is
rewritten: each file is written to a temporary name and moved over the old one with
``os.replace``, ``report.json`` last, so a reader never sees half a file. ``report.html``
reloads itself every interval while watching (the final one does not).

Stops with exit 0 after a final report on SIGINT/SIGTERM, with ``--once`` after one
pass, or when the writer has closed the log and no reading arrived for ``--idle``
seconds.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import signal
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Annotated, Any

import typer

from sonarproc.cli import app, fail, guarded
from sonarproc.cli_options import (
    BboxOption,
    CellOption,
    CentreOption,
    DropCrosstalkOption,
    FitOption,
    OrderOption,
    RobustOption,
    SmoothOption,
    SpanOption,
    TruthOption,
    build_run_params,
)

__all__ = ["WatchOutcome", "watch", "watch_command", "write_report_atomic"]

log = logging.getLogger(__name__)

# report.json last: a reader that polls it sees the other files of that update already.
_ORDER = ("arcmap.png", "processed.png", "fit.png", "profile.csv", "report.html", "report.json")


def write_report_atomic(
    result: Any, out_dir: Path, *, live: dict[str, Any], refresh_s: float | None
) -> dict[str, Any]:
    """Write a report directory with atomic per-file replacement.

    Parameters
    ----------
    result : RunResult
        The snapshot to report.
    out_dir : Path
        Report directory (created).
    live : dict
        Added to ``report.json`` as ``live`` (updates, readings seen, writer state).
    refresh_s : float or None
        ``report.html`` reloads itself after this many seconds; None: no reload.

    Returns
    -------
    dict
        The ``report.json`` content.
    """
    from sonarproc.report import write_report

    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".watch-", dir=out_dir))
    try:
        doc = write_report(result, tmp)
        doc["live"] = live
        (tmp / "report.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
        if refresh_s is not None:
            page = (tmp / "report.html").read_text(encoding="utf-8")
            meta = f'<meta http-equiv="refresh" content="{max(1, round(refresh_s))}">'
            page = page.replace("<head>", "<head>" + meta, 1)
            (tmp / "report.html").write_text(page, encoding="utf-8")
        for name in _ORDER:
            os.replace(tmp / name, out_dir / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return doc


@dataclass
class WatchOutcome:
    """How a watch ended."""

    reason: str  # "signal", "once", "closed"
    updates: int
    readings: int
    report: dict[str, Any] | None


def watch(
    log_path: Path,
    params: Any,
    out_dir: Path,
    *,
    interval: float = 2.0,
    idle: float = 10.0,
    once: bool = False,
    truth: Path | None = None,
    stop: threading.Event | None = None,
    status: Callable[[str], None] | None = None,
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

    Returns
    -------
    WatchOutcome

    Raises
    ------
    ValueError
        The log cannot be read at the start, or holds bad readings (as ``sonarproc run``).
    """
    from dataclasses import replace

    from sonarlog import SonarLogError, read_log
    from sonarproc.csvlog import read_truth_csv
    from sonarproc.live import LiveAccumulator, writer_closed

    stop = stop or threading.Event()
    truth_xy = read_truth_csv(truth) if truth is not None else None

    def read() -> Any:
        lg = read_log(log_path)
        return lg if truth_xy is None else replace(lg, truth=truth_xy)

    first = None
    while first is None:
        try:
            first = read()
        except (SonarLogError, OSError):
            # A log its writer has only just created may not be readable yet: wait for
            # it while the writer holds it open (or until told to stop).
            if not log_path.is_file() or writer_closed(log_path) or once or stop.is_set():
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
        closed = writer_closed(log_path)
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
            except ValueError as err:
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
                    result, out_dir, live=live, refresh_s=None if final else interval
                )
                if status is not None:
                    m = doc["metrics"]
                    status(
                        f"update {updates}: {seen} readings, "
                        f"{doc['counts']['readings_used']} used, e={m['e']}, f_c={m['f_c']}"
                        + (f", E1={m['E1_m']}" if "E1_m" in m else "")
                    )
        if final:
            if once and doc is None:
                # nothing to report: fail the way ``sonarproc run`` does on this log
                from sonarproc.pipeline import process

                process(lg if lg is not None else first, params)
            reason = "once" if once else ("signal" if stop.is_set() else "closed")
            break
        stop.wait(interval)
        if stop.is_set():
            continue  # one more pass: pick up the last readings, write the final report
    return WatchOutcome(reason, updates, seen, doc)


@app.command("watch")
def watch_command(
    log: Annotated[Path, typer.Argument(help="sonarlog v1 file being written (.h5).")],
    out: Annotated[
        Path | None, typer.Option("--out", help="Report directory (default: LOG_report/).")
    ] = None,
    interval: Annotated[float, typer.Option(help="Seconds between re-reads of the log.")] = 2.0,
    idle: Annotated[
        float,
        typer.Option(help="Stop when the writer closed the log and nothing arrived for S s."),
    ] = 10.0,
    once: Annotated[bool, typer.Option("--once", help="One pass, then stop.")] = False,
    cell: CellOption = 0.01,
    bbox: BboxOption = None,
    ops: Annotated[str, typer.Option(help="Morphological operations.")] = "thinning:3",
    fit: FitOption = "poly",
    order: OrderOption = None,
    smooth: SmoothOption = None,
    centre: CentreOption = None,
    truth: TruthOption = None,
    drop_crosstalk: DropCrosstalkOption = False,
    robust: RobustOption = "none",
    span: SpanOption = "truth",
) -> None:
    """Process a log while it is being written; keep the report directory current."""
    from sonarproc.report import default_out_dir

    stop = threading.Event()
    with guarded():
        if not (interval > 0):
            fail(f"--interval must be > 0 s, got {interval}")
        if not (idle >= 0):
            fail(f"--idle must be >= 0 s, got {idle}")
        params = build_run_params(
            cell=cell, bbox=bbox, ops=ops, fit=fit, order=order, smooth=smooth, centre=centre,
            drop_crosstalk=drop_crosstalk, robust=robust, span=span,
        )  # fmt: skip
        out_dir = out if out is not None else default_out_dir(log)

        def on_signal(signum: int, frame: FrameType | None) -> None:
            stop.set()

        previous = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous[sig] = signal.signal(sig, on_signal)
        try:
            outcome = watch(
                log,
                params,
                out_dir,
                interval=interval,
                idle=idle,
                once=once,
                truth=truth,
                stop=stop,
                status=lambda line: typer.echo(f"sonarproc watch: {line}", err=True),
            )
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
    if outcome.report is None:
        typer.echo(f"sonarproc: warning: {log}: no reading made an arc; no report", err=True)
    typer.echo(
        f"sonarproc watch: stopped ({outcome.reason}) after {outcome.updates} update(s), "
        f"{outcome.readings} readings; report in {out_dir}"
    )
