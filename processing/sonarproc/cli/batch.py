"""``sonarproc batch``: ``run`` over many logs, a report directory each, one summary table.

Thin: :mod:`sonarproc.batch` runs the logs (on :mod:`sonarproc.engines`) and writes the
reports and the summary; this module parses options, prints one line and maps the
outcome to an exit code.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sonarproc.cli.app import RuntimeProblem, app, guarded
from sonarproc.cli.options import (
    ArcStepOption,
    BboxOption,
    CellOption,
    CentreOption,
    DropCrosstalkOption,
    EngineOption,
    OrderOption,
    RobotOption,
    RunFitOption,
    RunOpsOption,
    RunRobustOption,
    SensorsOption,
    SmoothOption,
    SpanOption,
    WorkersOption,
    build_run_mode,
    worker_count,
)
from sonarproc.cli.paths import check_output_dir
from sonarproc.cli.progress import progress

__all__ = ["batch_command"]


@app.command("batch")
def batch_command(
    logs: Annotated[
        list[Path],
        typer.Argument(
            help="Logs: sonarlogs (.h5), readings CSVs, ROS 1 bags, ROS 2 bag directories, "
            "Player logs; any mix."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Output directory: one report directory per log (named from the log's "
            "file name) and summary.csv, summary.jsonl.",
        ),
    ],
    cell: CellOption = 0.01,
    bbox: BboxOption = None,
    ops: RunOpsOption = None,
    fit: RunFitOption = None,
    order: OrderOption = None,
    smooth: SmoothOption = None,
    centre: CentreOption = None,
    sensors: SensorsOption = None,
    robot: RobotOption = None,
    drop_crosstalk: DropCrosstalkOption = False,
    robust: RunRobustOption = None,
    span: SpanOption = "truth",
    arc_step: ArcStepOption = None,
    figures: Annotated[
        str,
        typer.Option(
            "--figures",
            metavar="FORMATS",
            help="Figure files in each report: none (default), png,svg, png or svg.",
        ),
    ] = "none",
    degrees: Annotated[
        bool, typer.Option("--degrees", help="Readings CSVs' theta and turret are in degrees.")
    ] = False,
    auto: Annotated[
        bool,
        typer.Option(
            "--auto",
            help="Choose the method, operations and fit per log by held-out range residual "
            "(as run --auto).",
        ),
    ] = False,
    paper: Annotated[
        bool,
        typer.Option("--paper", help="The paper's method exactly on every log (as run --paper)."),
    ] = False,
    engine: EngineOption = "local",
    workers: WorkersOption = 1,
) -> None:
    """Run 'sonarproc run' over many logs: a report per log and a summary table.

    A log that cannot be processed is an error row with its reason; the others go on.

    Exit code: 0 every log gave a report, 1 any log failed, 2 usage error (option, --out).
    """
    from sonarproc.batch import BatchOptions, run_batch, write_summary
    from sonarproc.engines import parse_engine
    from sonarproc.report.plots import parse_figure_formats

    with guarded():
        formats = parse_figure_formats(figures)
        mode, params = build_run_mode(
            auto=auto, paper=paper, cell=cell, bbox=bbox, ops=ops, fit=fit, order=order,
            smooth=smooth, centre=centre, drop_crosstalk=drop_crosstalk, robust=robust,
            span=span, arc_step_deg=arc_step,
        )  # fmt: skip
        n_workers = worker_count(workers)
        where = parse_engine(engine)
        check_output_dir(out)
        options = BatchOptions(
            params=params,
            figures=formats,
            sensors=None if sensors is None else str(sensors),
            robot=robot,
            degrees=degrees,
            mode=mode,
        )
        with progress("batch", len(logs)) as steps:
            result = run_batch(
                [str(p) for p in logs], out, options, engine=where, workers=n_workers,
                progress=steps,
            )  # fmt: skip
        csv_path, _ = write_summary(result.rows, out)
        typer.echo(
            f"sonarproc batch: {len(result.rows) - result.failed} of {len(result.rows)} logs "
            f"processed in {result.wall_s:.2f} s with {where.describe(n_workers)}; "
            f"summary: {csv_path}"
        )
        if result.failed:
            raise RuntimeProblem(
                f"{result.failed} of {len(result.rows)} logs failed (status 'error' in {csv_path})"
            )
