"""``sonarproc compare``: several map-building methods on one log, side by side.

Thin: the options become :class:`~sonarproc.params.RunParams` and method instances
(:mod:`sonarproc.methods`), the log is read once, :func:`~sonarproc.methods.compare.compare`
runs each method and :func:`~sonarproc.methods.compare.write_comparison` writes the files.
Errors become one line and an exit code through :func:`sonarproc.cli.guarded`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from sonarproc.cli.app import app, guarded, warn_if_damaged
from sonarproc.cli.options import (
    BboxOption,
    CellOption,
    DropCrosstalkOption,
    FiguresOption,
    FitOption,
    OpsOption,
    OrderOption,
    RobotOption,
    SensorsOption,
    TruthOption,
    build_run_params,
)
from sonarproc.cli.paths import check_output_dir
from sonarproc.cli.progress import progress
from sonarproc.errors import ParameterError

if TYPE_CHECKING:
    from sonarproc.methods import MapMethod

__all__ = ["build_methods", "compare_command"]

SetOption = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        help="A method option METHOD.OPTION=VALUE, e.g. occupancy.select=ridge (repeatable).",
    ),
]


def build_methods(names: list[str], settings: list[str] | None) -> list[MapMethod]:
    """Instances of ``names`` with their ``--set`` options (unused settings are an error)."""
    from sonarproc.methods import make_method, parse_settings

    opts = parse_settings(settings or [])
    extra = sorted(set(opts) - set(names))
    if extra:
        raise ParameterError("settings", f"names a method not being run: {', '.join(extra)}")
    return [make_method(n, **opts.get(n, {})) for n in names]


def _table(doc: dict[str, Any], out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    from sonarproc.report.units import MISSING, number, seconds, sig3

    table = Table(title=f"sonarproc compare: {doc['source']}")
    columns = ("method", "e", "f_c", "E1 (cm)", "E2", "t_cpu (s)", "points", "fit",
               "precision (cm)", "completeness", "surfaces")  # fmt: skip
    for col in columns:
        table.add_column(col, justify="left" if col == "method" else "right", no_wrap=True)
    for r in doc["methods"]:
        e1 = MISSING if r["E1_m"] is None else sig3(100 * r["E1_m"])
        precision = r.get("precision_m")
        table.add_row(
            r["method"],
            number(r["e"]),
            number(r["f_c"]),
            e1,
            number(r["E2"]),
            seconds(r["t_cpu_s"]).removesuffix(" s"),
            str(r["points"]),
            r["fit"],
            MISSING if precision is None else sig3(100 * precision),
            number(r.get("completeness")),
            str(r.get("surfaces", 0)),
        )
    console = Console()
    console.width = max(console.width, 140)
    console.print(table)
    console.print(f"written to {out}")


@app.command("compare")
def compare_command(
    log: Annotated[Path, typer.Argument(help="sonarlog v1 file (.h5), or a readings CSV.")],
    methods: Annotated[
        str | None,
        typer.Option(
            help="Comma-separated methods (default: all of morphological, arc-vote, "
            "directional-max, arc-median, triangulation, line-of-sight, histogram, occupancy)."
        ),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", help="Output directory (default: LOG_compare/).")
    ] = None,
    cell: CellOption = 0.01,
    bbox: BboxOption = None,
    ops: OpsOption = "thinning:3",
    fit: FitOption = "auto",
    order: OrderOption = None,
    sensors: SensorsOption = None,
    robot: RobotOption = None,
    truth: TruthOption = None,
    drop_crosstalk: DropCrosstalkOption = False,
    settings: SetOption = None,
    export: Annotated[
        str | None,
        typer.Option(
            help="Also export each method's map: ros-map, geojson, ply (comma-separated)."
        ),
    ] = None,
    figures: FiguresOption = "png",
    as_json: Annotated[
        bool, typer.Option("--json", help="Print compare.json to stdout instead of a table.")
    ] = False,
    auto: Annotated[
        bool,
        typer.Option(
            "--auto", help="Add a row 'auto': the configuration --auto chooses (no ground truth)."
        ),
    ] = False,
) -> None:
    """Run several map-building methods on one log with the same grid, fit and metrics."""
    from sonarproc.export import parse_formats, write_exports
    from sonarproc.methods import DEFAULT_METHODS, parse_method_list
    from sonarproc.methods.compare import compare, write_method_surfaces
    from sonarproc.pipeline import load_log
    from sonarproc.report.comparison import write_comparison
    from sonarproc.report.plots import parse_figure_formats

    with guarded():
        figure_formats = parse_figure_formats(figures)
        params = build_run_params(
            cell=cell, bbox=bbox, ops=ops, fit=fit, order=order, drop_crosstalk=drop_crosstalk
        )
        names = parse_method_list(methods) if methods is not None else list(DEFAULT_METHODS)
        instances = build_methods(names, settings)
        formats = parse_formats(export) if export is not None else []
        lg = load_log(log, sensors=sensors, truth=truth, robot=robot)
        warn_if_damaged(lg)
        from sonarproc.pipeline.alignment import align_log

        lg, aligned = align_log(lg)  # once, for every method (the drift correction of run)
        out_dir = out if out is not None else log.with_name(f"{log.stem}_compare")
        check_output_dir(out_dir)
        results = []
        with progress("compare", len(instances)) as steps:
            for k, method in enumerate(instances):
                steps.describe(method.name)
                results.extend(compare(lg, params, [method]))
                results[-1].run.alignment = aligned
                steps(k + 1)
        record = None
        if auto:
            from dataclasses import replace

            from sonarproc.auto import run_auto

            chosen_run, chosen, choice = run_auto(lg, params)
            results.append(replace(chosen_run, method="auto"))
            record = choice.to_json(chosen)
        doc = write_comparison(
            str(log), params, results, out_dir, auto=record, figures=figure_formats
        )
        for r, row in zip(results, doc["methods"], strict=True):
            write_method_surfaces(r, out_dir)
            if formats:
                write_exports(r, out_dir / "export", formats, log=lg)
            if not row["fit_ok"]:
                reason = getattr(r.run.fit, "reason", "")
                typer.echo(f"sonarproc: warning: {r.method}: fit failed: {reason}", err=True)
    if as_json:
        typer.echo(json.dumps(doc, indent=2))
    else:
        _table(doc, out_dir)
        if record is not None:
            from rich.console import Console

            from sonarproc.auto import record_table

            Console(width=max(Console().width, 120)).print(record_table(record))
