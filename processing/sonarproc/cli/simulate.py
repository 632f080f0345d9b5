"""``sonarproc simulate``: a scenario YAML in, a sonarlog v1 with ``/truth/profile`` out."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sonarproc.cli.app import app, guarded
from sonarproc.cli.paths import check_output_file


@app.command()
def simulate(
    scenario: Annotated[
        Path,
        typer.Argument(
            metavar="SCENARIO", help="Scenario YAML, or a shipped scenario's name (fig12)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="The sonarlog (.h5) to write.")],
    seed: Annotated[
        int | None,
        typer.Option("--seed", min=0, help="Override the scenario's seed (every random draw)."),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite OUT if it exists.")] = False,
) -> None:
    """Simulate SCENARIO's sonar readings into a sonarlog with the true surface profile."""
    from sonarproc.simulate import simulate_to_log

    with guarded():
        check_output_file(out, overwrite=force)
        summary = simulate_to_log(scenario, out, seed=seed, force=force)
    typer.echo(
        f"{summary.path}: {summary.readings} readings ({summary.echoes} echoes), "
        f"{summary.sensors} sensors, {summary.truth_points} truth points, "
        f"scenario {summary.scenario}, seed {summary.seed}"
    )
