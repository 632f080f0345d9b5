"""``nomad-emulator``: an emulated Nomad 200 on a pseudo-terminal.

Prints the pty path as the first line on stdout, then answers the Nomad protocol on it
until SIGTERM or SIGINT. Exit codes: 0 stopped, 1 runtime failure, 2 bad option or world.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from collections.abc import Sequence
from importlib import metadata
from typing import IO, NoReturn

from nomad200.codec import BAUD_RATES
from nomad200.emulator.device import EmulatorOptions, build_link
from nomad200.emulator.pty_server import PtyServer
from nomad200.emulator.rx import GAP_TIMEOUT

__all__ = ["main"]


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


DESCRIPTION = """\
An emulated Nomad 200 robot on a pseudo-terminal. Prints the pty path as the first line on
stdout, then answers the Nomad 200 serial protocol on it until SIGTERM or SIGINT.
Exit codes: 0 stopped, 1 runtime failure, 2 bad option or world."""

EPILOG = """\
in-process robot (no pty): the nomad:// pyserial URL
  Any program that opens its port with pyserial's serial_for_url (nomad200.Client, sonard
  --port) can use an emulated robot inside its own process instead of a device path:

    nomad://[NAME]?KEY=VALUE&KEY=VALUE...

  NAME tells robots apart (the same URL finds the same robot again). Query keys:
    world=NAME|PATH        shipped world name (lab, ...) or world YAML; none: no echoes
    baud=N                 line speed: 4800, 9600, 19200 or 38400 (default: the port's)
    fast=1                 virtual time: no real waiting
    seed=N                 seed of the fault generators
    garble=P, drop=P       per reply byte (robot to host) faults
    garble_rx=P, drop_rx=P per request byte (host to robot) faults
    stall=P, stall_for=S   per reply delay of S seconds
    unplug_at=S, unplug_for=S  the port vanishes S seconds after the robot is created
    trace=PATH             JSON lines of commands and firings with the TRUE pose

  example:  sonard --port 'nomad://?world=lab&fast=1&baud=38400' --plan translate"""


def _version() -> str:
    try:
        return metadata.version("sonarmorph")
    except metadata.PackageNotFoundError:
        return "unknown (not installed)"


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="nomad-emulator",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    p.add_argument(
        "--world", required=True, help="shipped world name (lab, ...) or sonarsim world YAML"
    )
    p.add_argument(
        "--baud",
        type=int,
        default=9600,
        choices=BAUD_RATES,
        metavar="N",
        help=f"line speed for timing: {', '.join(map(str, BAUD_RATES))} (9600)",
    )
    p.add_argument("--fast", action="store_true", help="no real waiting; virtual time")
    p.add_argument("--link", metavar="PATH", help="keep a symlink to the current pty here")
    p.add_argument("--trace", metavar="FILE", help="JSON lines: commands, firings, TRUE poses")
    p.add_argument(
        "--garble",
        type=float,
        default=0.0,
        metavar="RATE",
        help="probability per reply byte (robot to host) of being garbled",
    )
    p.add_argument(
        "--drop",
        type=float,
        default=0.0,
        metavar="RATE",
        help="probability per reply byte (robot to host) of being lost",
    )
    p.add_argument(
        "--garble-rx",
        type=float,
        default=0.0,
        metavar="RATE",
        help="probability per request byte (host to robot) of being garbled: the robot "
        "NAKs a damaged packet or ignores it",
    )
    p.add_argument(
        "--drop-rx",
        type=float,
        default=0.0,
        metavar="RATE",
        help="probability per request byte (host to robot) of being lost: the robot drops "
        f"the incomplete packet after its {GAP_TIMEOUT:g} s inter-byte timeout, unanswered",
    )
    p.add_argument("--stall", type=float, default=0.0, metavar="RATE", help="per reply")
    p.add_argument("--stall-for", type=float, default=2.0, metavar="S", help="stall length")
    p.add_argument(
        "--unplug-at", type=float, metavar="S", help="vanish S seconds after the host's first bytes"
    )
    p.add_argument("--unplug-for", type=float, default=2.0, metavar="S", help="outage length")
    p.add_argument("--seed", type=int, default=0, help="fault generator seed (both directions)")
    p.add_argument("-v", "--verbose", action="store_true", help="log to stderr")
    return p


def _message(err: Exception) -> str:
    """One line for ``err``, without the ``[Errno N]`` prefix of OS errors."""
    if isinstance(err, OSError) and err.strerror:
        return f"{err.filename}: {err.strerror}" if err.filename else err.strerror
    return str(err)


def _check_link(path: str) -> None:
    """Refuse a ``--link`` path whose folder cannot hold the symlink (one-line message)."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ValueError(f"--link {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"--link {path}: folder {folder} is not writable")
    if os.path.isdir(path) and not os.path.islink(path):
        raise ValueError(f"--link {path}: is a folder, expected a path for the symlink")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the emulator; return the exit code."""
    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="nomad-emulator: %(message)s",
    )
    opts = EmulatorOptions(
        world=args.world,
        baud=args.baud,
        fast=args.fast,
        seed=args.seed,
        garble=args.garble,
        drop=args.drop,
        stall=args.stall,
        stall_for=args.stall_for,
        garble_rx=args.garble_rx,
        drop_rx=args.drop_rx,
        unplug_at=args.unplug_at,
        unplug_for=args.unplug_for,
        trace=args.trace,
    )
    trace: IO[str] | None = None
    try:
        opts.validate()
        if args.link:
            _check_link(args.link)
        if args.trace:
            try:
                trace = open(args.trace, "w", encoding="utf-8", buffering=1)  # noqa: SIM115
            except OSError as err:
                raise ValueError(f"--trace {args.trace}: {err.strerror}") from err
        link = build_link(opts, trace=trace)
    except (ValueError, OSError) as err:
        if trace is not None:
            trace.close()
        print(f"nomad-emulator: error: {_message(err)}", file=sys.stderr)
        return 2
    stop = threading.Event()

    def _stop(signum: int, frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, _stop)
    server = PtyServer(
        link,
        fast=args.fast,
        link_path=args.link,
        unplug_at=args.unplug_at,
        unplug_for=args.unplug_for,
    )
    try:
        path = server.open()
        print(path, flush=True)
        server.serve(stop)
    except OSError as err:
        print(f"nomad-emulator: error: {_message(err)}", file=sys.stderr)
        return 1
    finally:
        server.close()
        if trace is not None:
            trace.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
