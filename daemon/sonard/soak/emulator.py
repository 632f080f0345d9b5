"""The soak's robot: ``nomad-emulator`` on a pty with one fault every ``--every`` seconds.

The faults take turns: ``garble`` (reply and request bytes damaged), ``drop`` (bytes lost
both ways), ``stall`` (replies held back longer than sonard's reply timeout), ``unplug``
(the pty vanishes and comes back under a new name behind the ``--link`` symlink, as a USB
adapter does). Each fault is written to ``--faults`` as one JSON line with its kind and
its UNIX start and end. Prints the link path, then serves until SIGTERM; SIGUSR1 stops
the injection (a fault under way runs to its end).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import IO, Any

from nomad200.emulator.device import EmulatorOptions, build_link
from nomad200.emulator.link import Link
from nomad200.emulator.pty_server import PtyServer

__all__ = ["FAULT_KINDS", "FaultSchedule", "main"]

FAULT_KINDS = ("garble", "drop", "stall", "unplug")
#: how long a garble or drop episode lasts (s)
EPISODE_S = 5.0
#: byte damage rate during an episode
RATE = 0.01
#: a stalled reply arrives this late (s): longer than sonard's 0.5 s timeout and 1 s link loss
STALL_S = 2.5
#: how long the port is gone when unplugged (s)
UNPLUG_S = 3.0


class FaultSchedule:
    """Inject the next fault every ``every`` seconds; unplugs go through the serve loop.

    Parameters
    ----------
    link : Link
        The emulated line whose :class:`Faults` rates are switched on and off.
    every : float
        Seconds between faults (the first comes after ``every``).
    log : file
        JSON lines: ``{"kind", "start", "end"}`` in UNIX seconds.
    """

    def __init__(self, link: Link, every: float, log: IO[str]) -> None:
        self.link = link
        self.every = every
        self.log = log
        self.unplug = threading.Event()
        self.session = threading.Event()
        self.count = 0
        #: set (SIGUSR1) to stop injecting: the kill trials measure crash loss, not outages
        self.paused = threading.Event()
        self._lock = threading.Lock()

    def record(self, kind: str, start: float, end: float) -> None:
        """Append one fault to the log (from the injector or the serve loop)."""
        with self._lock:
            self.log.write(json.dumps({"kind": kind, "start": start, "end": end}) + "\n")
            self.log.flush()

    def run(self, stop: threading.Event, started: Callable[[], bool] = lambda: True) -> None:
        """Loop until ``stop``: wait, inject, wait, inject...

        The first wait starts once ``started()`` (the host's first bytes): a sonard slow to
        start on a loaded machine meets its first fault mid-run, not while configuring.
        """
        while not started() and not stop.wait(0.05):
            pass
        while not stop.wait(self.every):
            if self.paused.is_set():
                continue
            kind = FAULT_KINDS[self.count % len(FAULT_KINDS)]
            self.count += 1
            if kind == "unplug":
                self.unplug.set()
                self.session.set()  # the serve loop returns and unplugs
                continue
            f = self.link.faults
            start = time.time()
            if kind == "garble":
                f.garble = f.garble_rx = RATE
                stop.wait(EPISODE_S)
                f.garble = f.garble_rx = 0.0
            elif kind == "drop":
                f.drop = f.drop_rx = RATE
                stop.wait(EPISODE_S)
                f.drop = f.drop_rx = 0.0
            else:  # stall: a few replies in a row come late
                f.stall_s, f.stall = STALL_S, 1.0
                stop.wait(0.2)
                f.stall = 0.0
            self.record(kind, start, time.time())


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m sonard.soak.emulator", description=__doc__)
    p.add_argument("--world", required=True)
    p.add_argument("--baud", type=int, default=38400)
    p.add_argument("--link", required=True, help="symlink to the current pty")
    p.add_argument("--trace", required=True, help="JSON lines: commands and firings")
    p.add_argument("--faults", required=True, help="JSON lines: the faults injected")
    p.add_argument("--every", type=float, default=60.0, help="seconds between faults")
    p.add_argument("--seed", type=int, default=0)
    return p


def _serve(server: PtyServer, schedule: FaultSchedule, stop: threading.Event) -> None:
    model: Any = server.model
    while not stop.is_set():
        schedule.session.clear()
        if stop.is_set():  # stopped between the check and the clear
            break
        server.serve(schedule.session)
        if stop.is_set() or not schedule.unplug.is_set():
            continue
        schedule.unplug.clear()
        start = time.time()
        model.emit({"type": "unplug", "t": model.clock_ms() / 1000.0})
        server.close()
        stop.wait(UNPLUG_S)
        path = server.open()
        model.advance()
        model.emit({"type": "replug", "t": model.clock_ms() / 1000.0, "path": path})
        schedule.record("unplug", start, time.time())


def main(argv: Sequence[str] | None = None) -> int:
    """Run the faulty emulator; return the exit code."""
    args = _parser().parse_args(argv)
    opts = EmulatorOptions(world=args.world, baud=args.baud, seed=args.seed)
    stop = threading.Event()
    with (
        open(args.trace, "w", encoding="utf-8", buffering=1 << 16) as trace,
        open(args.faults, "w", encoding="utf-8") as faults,
    ):
        link = build_link(opts, trace=trace)
        server = PtyServer(link, link_path=args.link)
        schedule = FaultSchedule(link, args.every, faults)

        def _stop(signum: int, frame: object) -> None:
            stop.set()
            schedule.session.set()  # the serve loop returns

        signal.signal(signal.SIGTERM, _stop)
        signal.signal(signal.SIGINT, _stop)
        signal.signal(signal.SIGUSR1, lambda signum, frame: schedule.paused.set())
        server.open()
        print(args.link, flush=True)
        injector = threading.Thread(
            target=schedule.run, args=(stop, lambda: server.host_seen), daemon=True
        )
        injector.start()
        try:
            _serve(server, schedule, stop)
        finally:
            server.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
