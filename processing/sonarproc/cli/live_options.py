"""The ``--foxglove [HOST:]PORT`` option shared by ``run``, ``watch`` (and ``export``'s mcap)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated

import typer

from sonarproc.cli.app import fail

__all__ = ["FoxgloveOption", "foxglove_endpoint", "listening", "require_foxglove"]

FoxgloveOption = Annotated[
    str | None,
    typer.Option(
        "--foxglove",
        metavar="[HOST:]PORT",
        help="Serve a live view to the Foxglove app on HOST:PORT (default host 127.0.0.1; "
        "port 0 picks a free one). Needs: pip install 'sonarmorph[live]'.",
    ),
]


def require_foxglove() -> None:
    """Exit 2 with a one-line how-to-install when ``foxglove-sdk`` is missing."""
    from sonarproc.live.endpoint import INSTALL_HINT, foxglove_missing

    if foxglove_missing():
        fail(INSTALL_HINT, 2)


def foxglove_endpoint(text: str) -> tuple[str, int]:
    """``(host, port)`` of a ``--foxglove`` value; exit 2 if the SDK is missing or it is bad."""
    from sonarproc.errors import ParameterError
    from sonarproc.live.endpoint import parse_endpoint

    require_foxglove()
    try:
        return parse_endpoint(text)
    except ParameterError as err:
        fail(str(err), 2)


def listening(command: str) -> Callable[[str, int], None]:
    """A callback printing where the server listens (tests and users read the port)."""

    def say(host: str, port: int) -> None:
        shown = f"[{host}]" if ":" in host else host
        typer.echo(f"sonarproc {command}: Foxglove live view on ws://{shown}:{port}")

    return say
