"""The ``--foxglove [HOST:]PORT`` option shared by ``run``, ``watch`` (and ``export``'s mcap)."""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Annotated, Any

import typer

from sonarproc.cli.app import fail, guarded

__all__ = ["FoxgloveOption", "foxglove_endpoint", "listening", "require_foxglove", "serve_run"]

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


def serve_run(
    log: Path,
    result: Any,
    endpoint: tuple[str, int],
    *,
    sensors: Path | None = None,
    truth: Path | None = None,
    robot: str | None = None,
) -> None:
    """``run --foxglove``: publish the finished run once, serve it until SIGINT/SIGTERM."""
    from sonarproc.live.session import LiveServer, serve_result
    from sonarproc.pipeline import load_log

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    with guarded():
        lg = load_log(log, sensors=sensors, truth=truth, robot=robot)
        server = LiveServer(*endpoint, sensors=lg.sensors, speed_of_sound=lg.speed_of_sound)
        previous = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous[sig] = signal.signal(sig, on_signal)
        try:
            listening("run")(endpoint[0], server.port)
            typer.echo("sonarproc run: serving the result; Ctrl-C to stop")
            serve_result(server, lg.readings, result, stop)
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            server.close()
