"""``sonarproc watch``: live processing of a log a writer is still writing.

The loop is :func:`sonarproc.pipeline.watch.watch`; this module only parses options,
installs the signal handlers that stop it, and prints.
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from types import FrameType
from typing import Annotated

import typer

from sonarproc.cli.app import app, fail, guarded
from sonarproc.cli.live_options import FoxgloveOption, foxglove_endpoint, listening
from sonarproc.cli.options import (
    BboxOption,
    CellOption,
    CentreOption,
    DropCrosstalkOption,
    FiguresOption,
    FitOption,
    OpsOption,
    OrderOption,
    RobustOption,
    SmoothOption,
    SpanOption,
    TruthOption,
    build_run_params,
)
from sonarproc.cli.paths import check_output_dir

__all__ = ["watch_command"]


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
    ops: OpsOption = "thinning:3",
    fit: FitOption = "auto",
    order: OrderOption = None,
    smooth: SmoothOption = None,
    centre: CentreOption = None,
    truth: TruthOption = None,
    drop_crosstalk: DropCrosstalkOption = False,
    robust: RobustOption = "none",
    span: SpanOption = "truth",
    figures: FiguresOption = "png",
    foxglove: FoxgloveOption = None,
) -> None:
    """Process a log while it is being written; keep the report directory current.

    With --foxglove the log is published live to the Foxglove app instead, and the report
    is written once, when the watch ends.
    """
    from sonarproc.pipeline.watch import watch
    from sonarproc.report import default_out_dir
    from sonarproc.report.plots import parse_figure_formats

    stop = threading.Event()
    with guarded():
        formats = parse_figure_formats(figures)
        if not (interval > 0):
            fail(f"--interval must be > 0 s, got {interval}")
        if not (idle >= 0):
            fail(f"--idle must be >= 0 s, got {idle}")
        params = build_run_params(
            cell=cell, bbox=bbox, ops=ops, fit=fit, order=order, smooth=smooth, centre=centre,
            drop_crosstalk=drop_crosstalk, robust=robust, span=span,
        )  # fmt: skip
        if foxglove is not None:
            from sonarproc.live.follow import live_watch

            watch = live_watch(*foxglove_endpoint(foxglove), on_listen=listening("watch"))
        out_dir = out if out is not None else default_out_dir(log)
        check_output_dir(out_dir)

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
                figures=formats,
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
