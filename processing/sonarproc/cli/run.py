"""``sonarproc run``: a log in, a report directory out (the report files of docs/formats.md).

Thin: parse options into :class:`~sonarproc.params.RunParams`, call
:func:`~sonarproc.pipeline.run_file` and :func:`~sonarproc.report.write_report`, print a
summary (or the JSON with ``--json``). Errors become one line and an exit code through
:func:`sonarproc.cli.guarded`.
"""

from __future__ import annotations

import json
import sys
import threading
from pathlib import Path
from typing import Annotated, Any

import typer

from sonarproc.cli.app import app, guarded
from sonarproc.cli.live_options import FoxgloveOption, foxglove_endpoint, serve_run
from sonarproc.cli.options import (
    ArcStepOption,
    BboxOption,
    CellOption,
    CentreOption,
    DropCrosstalkOption,
    FiguresOption,
    NoAlignOption,
    OrderOption,
    PoseFrameOption,
    RobotOption,
    RunFitOption,
    RunOpsOption,
    RunRobustOption,
    SensorsOption,
    SmoothOption,
    SpanOption,
    TruthOption,
    build_run_mode,
)
from sonarproc.cli.paths import check_output_dir

__all__ = ["run_command"]

_STAGES = (
    "read",
    "align",
    "select",
    "grid",
    "rasterise",
    "morphology",
    "fit",
    "metrics",
    "quality",
    "report",
)


class _DelayedProgress:
    """A transient rich progress bar on stderr that appears only after ``delay`` seconds."""

    def __init__(self, enabled: bool, delay: float = 1.0) -> None:
        self._progress: Any = None
        self._timer: threading.Timer | None = None
        self._lock = threading.Lock()
        self._started = False
        if not enabled:
            return
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self._progress = Progress(
            TextColumn("{task.description:<12}"),
            BarColumn(),
            TimeElapsedColumn(),
            console=Console(stderr=True),
            transient=True,
        )
        self._task = self._progress.add_task("read", total=len(_STAGES))
        self._timer = threading.Timer(delay, self._start)
        self._timer.daemon = True
        self._timer.start()

    def _start(self) -> None:
        with self._lock:
            if self._progress is not None and not self._started:
                self._progress.start()
                self._started = True

    def __call__(self, stage: str) -> None:
        if self._progress is not None and stage in _STAGES:
            self._progress.update(self._task, completed=_STAGES.index(stage), description=stage)

    def close(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer.join(timeout=1.0)
        with self._lock:
            if self._started:
                self._progress.stop()
            self._progress = None


def _summary(doc: dict[str, Any], out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    from sonarproc.report.plots import map_label
    from sonarproc.report.units import length_cm, number, seconds

    m, c, g, fit = doc["metrics"], doc["counts"], doc["grid"], doc["fit"]
    table = Table(title=f"sonarproc run: {doc['source']}", show_header=False)
    table.add_column(style="bold")
    table.add_column()
    table.add_row("readings used", f"{c['readings_used']} of {c['readings_total']}")
    no_echo = c.get("flagged_no_echo", 0)
    skipped = str(c["skipped_out_of_range"]) + (f" ({no_echo} no echo)" if no_echo else "")
    table.add_row("skipped out of range", skipped)
    table.add_row("map", f"{g['nx']} x {g['ny']} cells of {length_cm(g['cell'])}")
    table.add_row("operations", map_label(str(doc["parameters"]["ops"]), doc.get("auto")))
    fit_text = "spline" if fit["kind"] == "spline" else f"{fit['kind']}, order {fit.get('order')}"
    if fit["kind"] == "surfaces":
        kinds = ", ".join(f"{n} {k}" for k, n in fit.get("kinds", {}).items())
        text = f"{fit.get('surfaces', 0)} surfaces" + (f" ({kinds})" if kinds else "")
        if fit.get("failed"):
            text += f", {fit['failed']} not fitted"
        table.add_row("fit", text if fit["ok"] else f"{text}: FAILED ({fit.get('reason')})")
    else:
        table.add_row("fit", fit_text if fit["ok"] else f"{fit_text}: FAILED ({fit['reason']})")
    if (doc.get("auto") or {}).get("mode") == "default":
        table.add_row("chosen by", "held-out range residual, as --auto (--paper: the paper's)")
    table.add_row("e", number(m["e"]))
    table.add_row("f_c", number(m["f_c"]))
    if "E1_m" in m:
        table.add_row("E1", length_cm(m["E1_m"]))
        table.add_row("E2", number(m["E2"]))
    if "precision_m" in m:
        table.add_row("precision", length_cm(m["precision_m"]))
        table.add_row("completeness", number(m["completeness"]))
    q = doc.get("quality")
    if q:
        frac = q.get("explained_fraction")
        table.add_row(
            f"explained within {length_cm(q['tolerance_m'])}",
            "n/a" if frac is None else f"{frac:.2f} of {q['explained_readings']} readings",
        )
        med, p90 = q.get("heldout_residual_median_m"), q.get("heldout_residual_p90_m")
        table.add_row(
            "held-out residual",
            f"median {length_cm(med)}, p90 {length_cm(p90)}"
            if med is not None and p90 is not None
            else f"n/a ({q.get('reason')})",
        )
    al = doc.get("alignment")
    if al:
        table.add_row(
            "drift correction",
            f"applied: up to {length_cm(al['max_shift_m'])}" if al["applied"]
            else f"not applied: {al['reason']}",
        )  # fmt: skip
    table.add_row("t_cpu", seconds(m["t_cpu_s"]))
    table.add_row("report", str(out))
    Console().print(table)


@app.command("run")
def run_command(
    log: Annotated[Path, typer.Argument(help="sonarlog v1 file (.h5), or a readings CSV.")],
    out: Annotated[
        Path | None, typer.Option("--out", help="Report directory (default: LOG_report/).")
    ] = None,
    cell: CellOption = 0.01,
    bbox: BboxOption = None,
    ops: RunOpsOption = None,
    fit: RunFitOption = None,
    order: OrderOption = None,
    smooth: SmoothOption = None,
    centre: CentreOption = None,
    sensors: SensorsOption = None,
    robot: RobotOption = None,
    truth: TruthOption = None,
    drop_crosstalk: DropCrosstalkOption = False,
    robust: RunRobustOption = None,
    span: SpanOption = "truth",
    arc_step: ArcStepOption = None,
    figures: FiguresOption = "png",
    no_align: NoAlignOption = False,
    pose_frame: PoseFrameOption = None,
    degrees: Annotated[
        bool, typer.Option("--degrees", help="A readings CSV's theta and turret are in degrees.")
    ] = False,
    as_json: Annotated[
        bool, typer.Option("--json", help="Print report.json to stdout instead of a table.")
    ] = False,
    auto: Annotated[
        bool,
        typer.Option(
            "--auto",
            help="Choose the method, operations and fit by held-out range residual (no "
            "ground truth) on any log, a room included; --ops, --fit, --order, --smooth, "
            "--robust are then ignored.",
        ),
    ] = False,
    paper: Annotated[
        bool,
        typer.Option(
            "--paper",
            help="The paper's method exactly: --ops thinning:3, a polynomial of order 9 "
            "(for one curve). Without --paper, --auto or a fit option, a one-curve log's "
            "fit is chosen as --auto chooses it.",
        ),
    ] = False,
    foxglove: FoxgloveOption = None,
) -> None:
    """Turn a sonar log into an arc map, a processed map, a fitted profile and a report.

    With --foxglove the result is then served to the Foxglove app until Ctrl-C.
    """
    from sonarproc.fit import FitFailure
    from sonarproc.pipeline.run import import_stage_modules
    from sonarproc.report import default_out_dir, write_report
    from sonarproc.report.ahead import AheadFigures
    from sonarproc.report.plots import parse_figure_formats
    from sonarproc.run_modes import run_log
    from sonarproc.runtime import loading_modules

    with guarded():
        formats = parse_figure_formats(figures)
        mode, params = build_run_mode(
            auto=auto, paper=paper, cell=cell, bbox=bbox, ops=ops, fit=fit, order=order,
            smooth=smooth, centre=centre, drop_crosstalk=drop_crosstalk, robust=robust,
            span=span, arc_step_deg=arc_step, align=not no_align,
        )  # fmt: skip
        endpoint = foxglove_endpoint(foxglove) if foxglove is not None else None
        out_dir = out if out is not None else default_out_dir(log)
        check_output_dir(out_dir)
        # A child imports matplotlib meanwhile, on the second core, and draws as the map
        # and the result come; forked first (it needs none of the modules the run loads
        # next) and before the progress bar's thread (no fork beside one).
        ahead = AheadFigures.start(formats)
        # the stages' modules, loaded now (run_log would load them first thing) out of
        # the collector's sight (sonarproc.runtime)
        with loading_modules():
            import_stage_modules(params)
        progress = _DelayedProgress(enabled=sys.stderr.isatty() and not as_json and not auto)
        try:
            read = {
                "sensors": sensors, "truth": truth, "robot": robot, "degrees": degrees,
                "pose_frame": pose_frame,
            }  # fmt: skip
            result, record = run_log(
                log, params, mode, read=read, progress=progress,
                on_fitted=ahead.send if ahead is not None else None,
                on_mapped=ahead.send_map if ahead is not None else None,
            )  # fmt: skip
            if result.log_warning:
                typer.echo(f"sonarproc: warning: {result.log_warning}", err=True)
            progress("report")
            if not as_json:
                # the summary's modules, loaded now: the report next waits for the
                # figures' child, which is still drawing (this process is idle then)
                import rich.console
                import rich.table  # noqa: F401
            doc = write_report(result, out_dir, auto=record, figures=formats, ahead=ahead)
        finally:
            progress.close()
            if ahead is not None:
                ahead.cancel()
        if result.surfaces is not None and not result.surfaces.surfaces:
            reason = result.surfaces.reason or "no group of cells was long enough"
            typer.echo(f"sonarproc: warning: no surface found: {reason}", err=True)
        elif isinstance(result.fit, FitFailure) and result.surfaces is None:
            typer.echo(f"sonarproc: warning: fit failed: {result.fit.reason}", err=True)
    if as_json:
        typer.echo(json.dumps(doc, indent=2))
    else:
        _summary(doc, out_dir)
        if record is not None and mode == "auto":
            from rich.console import Console

            from sonarproc.auto import record_table

            Console().print(record_table(record))
    if endpoint is not None:
        serve_run(log, result, endpoint, sensors=sensors, truth=truth, robot=robot)
