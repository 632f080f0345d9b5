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

__all__ = [
    "FoxgloveOption",
    "export_mcap",
    "foxglove_endpoint",
    "listening",
    "require_foxglove",
    "serve_run",
    "split_mcap",
]

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


def split_mcap(formats: str) -> tuple[list[str], bool]:
    """The ``--format`` list without ``mcap``, and whether ``mcap`` was in it.

    Examples
    --------
    >>> split_mcap("ros-map, mcap"), split_mcap("geojson")
    ((['ros-map'], True), (['geojson'], False))
    """
    names = [f.strip() for f in formats.split(",") if f.strip()]
    return [f for f in names if f != "mcap"], "mcap" in names


def export_mcap(result: Any, lg: Any, params: Any, out_dir: Path, *, force: bool = False) -> Path:
    """``export --format mcap``: ``OUT/<method>.mcap`` (exit 2 without the SDK)."""
    require_foxglove()
    from sonarproc.live.mcap_export import write_mcap

    out_dir.mkdir(parents=True, exist_ok=True)
    live_params = params if result.method == "morphological" else None
    path = out_dir / f"{result.method}.mcap"
    return write_mcap(lg, result.run, path, params=live_params, force=force)
