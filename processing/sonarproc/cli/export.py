"""``sonarproc export``: one method's map of a log as files robotics tools read.

Formats (:mod:`sonarproc.export`): ``ros-map`` (map_server PGM + YAML, the fitted surfaces
drawn occupied), ``geojson`` (one LineString per fitted surface, or the fitted profile, in
the map frame), ``ply`` (the processed cells as a point cloud, and the surfaces' points),
``rosbag2`` (the readings replayed over the surfaces). ``sonarproc compare --export ...``
writes the same files for every method.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sonarproc.cli.app import app, guarded, warn_if_damaged
from sonarproc.cli.compare import SetOption, build_methods
from sonarproc.cli.live_options import export_mcap, require_foxglove, split_mcap
from sonarproc.cli.options import (
    BboxOption,
    CellOption,
    DropCrosstalkOption,
    FitOption,
    OpsOption,
    OrderOption,
    RobotOption,
    SensorsOption,
    build_run_params,
)
from sonarproc.cli.paths import check_output_dir
from sonarproc.errors import ParameterError

__all__ = ["export_command"]


@app.command("export")
def export_command(
    log: Annotated[Path, typer.Argument(help="sonarlog v1 file (.h5), or a readings CSV.")],
    fmt: Annotated[
        str,
        typer.Option("--format", help="ros-map, geojson, ply, rosbag2, mcap (comma-separated)."),
    ] = "ros-map,geojson",
    method: Annotated[str, typer.Option(help="Map-building method.")] = "morphological",
    out: Annotated[
        Path | None, typer.Option("--out", help="Output directory (default: LOG_export/).")
    ] = None,
    cell: CellOption = 0.01,
    bbox: BboxOption = None,
    ops: OpsOption = "thinning:3",
    fit: FitOption = "auto",
    order: OrderOption = None,
    sensors: SensorsOption = None,
    robot: RobotOption = None,
    truth: Annotated[
        Path | None, typer.Option(help="True profile CSV (x,y), for the metrics in the GeoJSON.")
    ] = None,
    drop_crosstalk: DropCrosstalkOption = False,
    settings: SetOption = None,
    force: Annotated[
        bool, typer.Option("--force", help="Replace an existing rosbag2 or mcap.")
    ] = False,
) -> None:
    """Export one method's map of a log: ROS map, GeoJSON profile, PLY cloud, ROS 2 bag."""
    from sonarproc.export import parse_formats, write_exports
    from sonarproc.methods import parse_method_list
    from sonarproc.pipeline import load_log

    with guarded():
        params = build_run_params(
            cell=cell, bbox=bbox, ops=ops, fit=fit, order=order, drop_crosstalk=drop_crosstalk
        )
        names = parse_method_list(method)
        if len(names) != 1:
            raise ParameterError(
                "method", "takes one method (use sonarproc compare --export for more)"
            )
        (instance,) = build_methods(names, settings)
        formats, mcap = split_mcap(fmt)
        formats = parse_formats(",".join(formats)) if formats else []
        if mcap:
            require_foxglove()  # before any file is written
        lg = load_log(log, sensors=sensors, truth=truth, robot=robot)
        warn_if_damaged(lg)
        out_dir = out if out is not None else log.with_name(f"{log.stem}_export")
        check_output_dir(out_dir)
        result = instance.run(lg, params)
        paths = write_exports(result, out_dir, formats, log=lg, force=force)
        if mcap:
            paths.append(export_mcap(result, lg, params, out_dir, force=force))
    for p in paths:
        typer.echo(str(p))
