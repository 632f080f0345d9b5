"""``nomad-emulator``: an emulated Nomad 200 on a pseudo-terminal.

Prints the pty path as the first line on stdout, then answers the Nomad protocol on it
until SIGTERM or SIGINT. Exit codes: 0 stopped, 1 runtime failure, 2 bad option or world.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from typing import IO, NoReturn

from nomad200.emulator.device import EmulatorOptions, build_link
from nomad200.emulator.pty_server import PtyServer
from nomad200.emulator.rx import GAP_TIMEOUT

__all__ = ["main"]


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="nomad-emulator", description=__doc__.splitlines()[0] if __doc__ else None)
    p.add_argument("--world", required=True, help="sonarsim world YAML")
    p.add_argument("--baud", type=int, default=9600, help="line speed for timing (9600)")
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
    p.add_argument("--unplug-at", type=float, metavar="S", help="vanish S seconds after start")
    p.add_argument("--unplug-for", type=float, default=2.0, metavar="S", help="outage length")
    p.add_argument("--seed", type=int, default=0, help="fault generator seed (both directions)")
    p.add_argument("-v", "--verbose", action="store_true", help="log to stderr")
    return p


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
        if args.trace:
            trace = open(args.trace, "w", encoding="utf-8", buffering=1)  # noqa: SIM115
        link = build_link(opts, trace=trace)
    except (ValueError, OSError) as err:
        print(f"nomad-emulator: error: {err}", file=sys.stderr)
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
        print(f"nomad-emulator: error: {err}", file=sys.stderr)
        return 1
    finally:
        server.close()
        if trace is not None:
            trace.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
