"""``sonard``: run an acquisition plan on a Nomad 200 and log pose-tagged sonar readings.

Usage::

    sonard --port PORT --plan PLAN.yaml [--out LOG.h5] [--baud N] [--fault-timeout S]
           [--truth WORLD.yaml] [-v] [--version]

Exit codes: 0 the plan completed (or a stop was requested), 1 runtime failure (including
a log or port held by another process, named by PID), 2 usage or configuration error.
Messages go to stderr through :mod:`logging`; under systemd (``$JOURNAL_STREAM`` set)
they carry no timestamps, journald adds its own.
"""

from __future__ import annotations

import argparse
import datetime as dt
import logging
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sonard.plan import BAUD_RATES, PlanError, load_plan
from sonarsim.shipped import resolve_shipped

__all__ = ["default_out", "main"]

log = logging.getLogger("sonard")


def default_out(env: dict[str, str] | None = None, now: dt.datetime | None = None) -> Path:
    """``$STATE_DIRECTORY`` (first entry) or the current directory, timestamped name.

    Examples
    --------
    >>> default_out({"STATE_DIRECTORY": "/var/lib/sonard"},
    ...             dt.datetime(2026, 1, 2, 3, 4, 5, tzinfo=dt.timezone.utc)).as_posix()
    '/var/lib/sonard/sonard-20260102T030405Z.h5'
    """
    env = dict(os.environ) if env is None else env
    now = now or dt.datetime.now(dt.timezone.utc)
    state = env.get("STATE_DIRECTORY", "").split(":")[0]
    base = Path(state) if state else Path.cwd()
    return base / f"sonard-{now.strftime('%Y%m%dT%H%M%SZ')}.h5"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="sonard",
        description="Run an acquisition plan on a Nomad 200 and log pose-tagged sonar "
        "readings to a sonarlog v1 file.",
    )
    p.add_argument("--port", required=True, help="serial device or pyserial URL (nomad://...)")
    p.add_argument("--plan", required=True, type=Path, help="plan YAML (m, s, degrees)")
    p.add_argument(
        "--out", type=Path, help="log file (default: $STATE_DIRECTORY or ., timestamped)"
    )
    p.add_argument("--baud", type=int, choices=BAUD_RATES, help="override the plan's baud rate")
    p.add_argument(
        "--fault-timeout",
        type=float,
        metavar="S",
        help="abort when the link stays down this long (overrides fault_timeout_s)",
    )
    p.add_argument(
        "--truth",
        type=Path,
        metavar="WORLD.yaml",
        help="store this sonarsim world's truth profile in the log (emulator runs: lets "
        "sonarproc report E1/E2)",
    )
    p.add_argument(
        "--foxglove",
        metavar="[HOST:]PORT",
        help="serve readings, pose and path live to the Foxglove app (host default "
        "127.0.0.1; port 0 picks a free one; needs: pip install 'sonarmorph[live]')",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv debug)")
    p.add_argument("--version", action="version", version=f"sonard {_version()}")
    return p


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("sonarmorph")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def _setup_logging(verbose: int) -> None:
    fmt = "%(levelname)s %(name)s: %(message)s"
    if not os.environ.get("JOURNAL_STREAM"):
        fmt = "%(asctime)s " + fmt
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(fmt))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(logging.WARNING)
    level = logging.DEBUG if verbose > 1 else logging.INFO
    for name in ("sonard", "nomad200", "sonarlog"):
        logging.getLogger(name).setLevel(level if verbose or name == "sonard" else logging.WARNING)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 success, 1 runtime failure, 2 usage or configuration error.
    """
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exc:  # argparse already printed the usage line
        return int(exc.code or 0)
    _setup_logging(args.verbose)
    try:
        plan = load_plan(args.plan)
    except PlanError as exc:
        print(f"sonard: {exc}", file=sys.stderr)
        return 2
    if args.fault_timeout is not None and args.fault_timeout < 0:
        print("sonard: --fault-timeout: must be 0 s or more", file=sys.stderr)
        return 2
    out: Path = args.out or default_out()
    if not out.parent.is_dir():
        print(f"sonard: --out: directory {out.parent} does not exist", file=sys.stderr)
        return 2

    truth = None
    if args.truth is not None:
        try:
            from sonarsim import load_world

            truth = load_world(args.truth).truth_profile()
        except Exception as exc:
            print(f"sonard: --truth: {exc}", file=sys.stderr)
            return 2

    live = None
    if args.foxglove is not None:
        live = _live_view(args.foxglove, plan.speed_of_sound)
        if isinstance(live, int):
            return live

    # imports h5py and the driver: keep --help fast
    from sonard.daemon import run
    from sonard.log_lock import LockBusy, LogExists
    from sonard.port_lock import PortUnavailable

    try:
        result = run(
            args.port,
            plan,
            out,
            plan_text=resolve_shipped(args.plan, kind="plans").read_text(encoding="utf-8"),
            baud=args.baud,
            fault_timeout_s=args.fault_timeout,
            truth=truth,
            live=live,
        )
    except LogExists as exc:
        print(f"sonard: --out: {exc}", file=sys.stderr)
        return 2
    except (LockBusy, PortUnavailable) as exc:
        log.error("%s", exc)
        return 1
    except OSError as exc:  # the log file could not be created
        log.error("cannot create %s: %s", out, exc.strerror or exc)
        return 1
    finally:
        if live is not None:
            live.close()
    if result.code:
        log.error("%s", result.reason)
    return result.code


def _live_view(endpoint: str, speed_of_sound: float) -> Any:
    """Start ``--foxglove``'s server; an exit code (2 usage, 1 runtime) when it cannot."""
    import importlib.util

    from sonarlog.foxglove_messages import parse_endpoint

    if importlib.util.find_spec("foxglove") is None:
        print("sonard: --foxglove needs the Foxglove SDK: pip install 'sonarmorph[live]'",
              file=sys.stderr)  # fmt: skip
        return 2
    try:
        host, port = parse_endpoint(endpoint)
    except ValueError as exc:
        print(f"sonard: --foxglove: {exc}", file=sys.stderr)
        return 2
    from sonard.live_view import LiveView
    from sonard.ring import ring_sensors

    try:
        view = LiveView(host, port, ring_sensors(), speed_of_sound)
    except OSError as exc:
        log.error("--foxglove: %s", exc)
        return 1
    shown = f"[{host}]" if ":" in host else host
    log.info("Foxglove live view on ws://%s:%d", shown, view.port)
    return view


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
