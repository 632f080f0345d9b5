"""``sonarproc recover``: write a clean copy of a crashed or cut sonarlog."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sonarproc.cli.app import app, guarded
from sonarproc.cli.paths import check_output_file


@app.command()
def recover(
    log: Annotated[Path, typer.Argument(metavar="LOG", help="The damaged sonarlog (.h5).")],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out", "-o", help="Where to write the clean copy [default: LOG.recovered.h5]."
        ),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite OUT if it exists.")] = False,
) -> None:
    """Copy every intact reading of LOG into a new, cleanly closed sonarlog."""
    from sonarlog import recover_log

    with guarded():
        if out is not None:
            check_output_file(out, overwrite=force)
        report = recover_log(log, out, force=force)
    typer.echo(
        f"{report.destination}: {report.readings} readings kept, "
        f"{report.dropped_rows} torn row(s) dropped, {report.poses} poses, {report.events} events"
    )
