"""``sonarproc import``: any robot's log (ROS 1/2 bag, Player log, readings CSV, sonarlog)
to sonarlog v1.

The reading, pose interpolation, stale-reading removal and mounts are
:mod:`sonarlog.sources`; this module parses options and prints what was found.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Annotated

import typer

from sonarproc.cli.app import app, fail, guarded
from sonarproc.cli.paths import check_output_file
from sonarproc.cli.progress import progress

__all__ = ["import_command", "shipped_preset_names"]


def shipped_preset_names() -> list[str]:
    """The robot presets ``--robot`` takes: the sensors files shipped with ``sonarsim``.

    Read from the package's ``data/sensors`` folder without importing ``sonarsim`` (whose
    import costs most of a second), so ``--help`` lists exactly what
    :func:`sonarlog.sources.preset_names` loads and cannot drift from it.
    """
    spec = importlib.util.find_spec("sonarsim")
    if spec is None or not spec.submodule_search_locations:
        return []
    folder = Path(next(iter(spec.submodule_search_locations))) / "data" / "sensors"
    return sorted(p.stem for p in folder.glob("*.yaml"))


_ROBOT_HELP = f"Mount preset: {', '.join(shipped_preset_names())}, or ring-N[-R]."


@app.command("import")
def import_command(
    log: Annotated[
        Path,
        typer.Argument(
            metavar="LOG",
            help="A ROS 1 .bag, a ROS 2 bag directory, a Player log, a readings CSV "
            "(with --sensors or --robot) or a sonarlog.",
        ),
    ],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="The sonarlog to write (.h5).")
    ] = None,
    sonar_topic: Annotated[
        str | None, typer.Option("--sonar-topic", help="Sonar topic(s) or Player device.")
    ] = None,
    odom_topic: Annotated[
        str | None, typer.Option("--odom-topic", help="Pose topic (Odometry, PoseStamped, /tf).")
    ] = None,
    pose_frame: Annotated[
        str | None,
        typer.Option(
            "--pose-frame",
            help="Poses in this fixed frame of the bag's tf tree (e.g. map: map -> odom -> "
            "base_link composed).",
        ),
    ] = None,
    robot: Annotated[str | None, typer.Option("--robot", help=_ROBOT_HELP)] = None,
    sensors: Annotated[
        Path | None, typer.Option("--sensors", help="Sensors YAML with the mounts.")
    ] = None,
    temperature: Annotated[
        float | None, typer.Option("--temperature", help="Air temperature (°C).")
    ] = None,
    truth: Annotated[
        Path | None,
        typer.Option(
            "--truth",
            help="True profile CSV (x,y; polylines separated by a blank line or a nan,nan "
            "row), stored as /truth/profile.",
        ),
    ] = None,
    degrees: Annotated[
        bool, typer.Option("--degrees", help="A readings CSV's theta and turret are in degrees.")
    ] = False,
    list_only: Annotated[
        bool, typer.Option("--list", help="Show the topics found and which would be used.")
    ] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite OUT if it exists.")] = False,
) -> None:
    """Convert LOG to a sonarlog v1 file (or, with --list, show what it holds)."""
    from rich.console import Console
    from rich.table import Table

    from sonarlog.sources import import_to_sonarlog, list_source

    with guarded():
        if list_only:
            rows = list_source(log)
            table = Table(title=f"sonarproc import --list: {log}")
            for col in ("topic", "type", "messages", "use", "why"):
                # fold, never cut: a topic or type name is what the user types next
                table.add_column(col, overflow="fold")
            for r in rows:
                table.add_row(r.name, r.msgtype, str(r.count), r.role or "-", r.reason)
            Console().print(table)
            return
        if out is None:
            fail("--out is required (the sonarlog to write), or pass --list")
        check_output_file(out)
        with progress(f"import {log.name}", None):
            summary = import_to_sonarlog(
                log, out, force=force, sonar_topic=sonar_topic, odom_topic=odom_topic,
                robot=robot, sensors=sensors, temperature_c=temperature, degrees=degrees,
                truth=truth, pose_frame=pose_frame,
            )  # fmt: skip
    for line in summary.lines():
        typer.echo(f"sonarproc import: {line}", err=True)
    typer.echo(f"{out}: written")
