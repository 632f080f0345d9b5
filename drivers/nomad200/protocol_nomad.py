"""pyserial URL handler ``nomad://``: an emulated Nomad 200 inside this process.

Importing :mod:`nomad200` adds the package to ``serial.protocol_handler_packages``, so
``serial.serial_for_url("nomad://?world=lab&fast=1")`` (and therefore
``nomad200.Client`` and ``sonard --port``) talks to an emulated robot.

URL: ``nomad://[NAME]?option=value&...``. The robot lives as long as the process (or until
:func:`reset_devices`): closing and reopening the same URL finds the same robot, as a real
robot keeps running while its cable is out. Use ``NAME`` (or any differing option) to get
separate robots.

Query options
-------------
world=NAME or world=PATH
    A shipped world name (``lab``) or a sonarsim world YAML (``start_pose`` sets the
    power-on pose). Without it: no echoes.
baud=N
    Line speed for timing: 4800, 9600, 19200 or 38400 (default: the port's baud rate when
    first opened).
fast=1
    No real waiting: simulated time is virtual and advances by the wire time of each
    byte (and by the host's timeouts), so the robot moves and fires plausibly.
seed=N
    Seed of the fault generators (default 0; one stream per direction).
garble=P, drop=P
    Probability per reply byte (robot to host) of being replaced by another byte / lost.
garble_rx=P, drop_rx=P
    Probability per request byte (host to robot) of being replaced by another byte / lost.
    The robot answers a damaged request with one NAK (bad checksum or end byte) or not at
    all (a lost start byte, an implausible length, or a packet left incomplete: dropped
    after the robot's 0.1 s inter-byte timeout), as the real robot does.
stall=P, stall_for=S
    Probability per reply of being delayed by S seconds (default 2).
unplug_at=S, unplug_for=S
    S seconds (real time) after the robot is created the port vanishes for ``unplug_for``
    seconds (default 2): reads and writes fail and opening fails, as on a USB unplug.
trace=PATH
    Append JSON lines of commands and sonar firings with the TRUE pose.
"""

from __future__ import annotations

import threading
import time
import weakref
from typing import IO, Any, Final
from urllib.parse import parse_qs, urlparse

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from nomad200.emulator.device import EmulatorOptions, build_link
from nomad200.emulator.link import Delivery, Link

__all__ = ["URL_KEYS", "Serial", "open_ports", "parse_url", "reset_devices"]

_FLOATS = (
    "garble",
    "drop",
    "garble_rx",
    "drop_rx",
    "stall",
    "stall_for",
    "unplug_at",
    "unplug_for",
)
_INTS = ("baud", "seed")
#: Every query key a ``nomad://`` URL accepts.
URL_KEYS: Final = ("world", "baud", "fast", "seed", *_FLOATS, "trace")


def parse_url(url: str) -> tuple[str, EmulatorOptions, bool]:
    """Parse a ``nomad://`` URL into (robot key, options, whether baud was given).

    Raises
    ------
    ValueError
        Wrong scheme, unknown option or a bad value.
    """
    parts = urlparse(url)
    if parts.scheme != "nomad":
        raise ValueError(f"expected a nomad:// URL, got {url!r}")
    opts = EmulatorOptions()
    q = parse_qs(parts.query, keep_blank_values=True)
    for key, vals in q.items():
        val = vals[-1]
        try:
            if key in _FLOATS:
                setattr(opts, key, float(val))
            elif key in _INTS:
                setattr(opts, key, int(val))
            elif key == "fast":
                opts.fast = val.lower() in ("1", "true", "yes", "on", "")
            elif key in ("world", "trace"):
                setattr(opts, key, val or None)
            else:
                raise ValueError(f"unknown option {key!r}")
        except ValueError as err:
            raise ValueError(f"{url}: {err}") from err
    opts.validate()
    return url, opts, "baud" in q


class _Device:
    def __init__(self, opts: EmulatorOptions) -> None:
        self.opts = opts
        self.trace: IO[str] | None = (
            open(opts.trace, "a", encoding="utf-8", buffering=1) if opts.trace else None  # noqa: SIM115
        )
        self.link: Link = build_link(opts, trace=self.trace)
        self.clock: Any = self.link.model.clock
        self.created = time.monotonic()
        self.users = 0

    def unplugged(self) -> bool:
        at = self.opts.unplug_at
        if at is None:
            return False
        dt = time.monotonic() - self.created - at
        return 0.0 <= dt < self.opts.unplug_for

    def close(self) -> None:
        if self.trace is not None:
            self.trace.close()
            self.trace = None


_DEVICES: dict[str, _Device] = {}
_LOCK = threading.Lock()
_OPEN: weakref.WeakSet[Serial] = weakref.WeakSet()


def reset_devices() -> None:
    """Forget every emulated robot (closes their trace files)."""
    with _LOCK:
        for dev in _DEVICES.values():
            dev.close()
        _DEVICES.clear()


def open_ports() -> list[Serial]:
    """``nomad://`` ports that are open (for leak checks in tests)."""
    return [p for p in _OPEN if p.is_open]


class Serial(SerialBase):
    """A pyserial port connected to an emulated Nomad 200."""

    is_open: bool

    def open(self) -> None:
        """Connect to the robot named by the URL (created on first use)."""
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        if self.is_open:
            raise SerialException("Port is already open.")
        try:
            key, opts, has_baud = parse_url(self.portstr)
        except ValueError as err:
            raise SerialException(str(err)) from err
        if not has_baud:
            opts.baud = int(self._baudrate)
        with _LOCK:
            dev = _DEVICES.get(key)
            if dev is None:
                try:
                    dev = _Device(opts)
                except (ValueError, OSError) as err:
                    raise SerialException(f"could not open port {key}: {err}") from err
                _DEVICES[key] = dev
            if dev.unplugged():
                raise SerialException(f"could not open port {key}: no such device (unplugged)")
            if self._exclusive and dev.users:
                raise SerialException(f"Could not exclusively lock port {key}: in use")
            dev.users += 1
        self._dev = dev
        self._rx = bytearray()
        self._pending: list[Delivery] = []
        self.is_open = True
        _OPEN.add(self)

    def close(self) -> None:
        """Disconnect (the robot keeps running)."""
        if self.is_open:
            self.is_open = False
            with _LOCK:
                self._dev.users -= 1
            _OPEN.discard(self)

    def _reconfigure_port(self) -> None:
        pass

    # ------------------------------------------------------------ data
    def _check(self) -> _Device:
        if not self.is_open:
            raise PortNotOpenError()
        dev = self._dev
        if dev.unplugged():
            raise SerialException("read failed: device disconnected (unplugged)")
        return dev

    def _deliver(self, horizon: float) -> None:
        """Move pending replies that have arrived by now (+ horizon in fast mode) into rx."""
        if not self._pending:
            return
        dev = self._dev
        if dev.opts.fast:
            limit = dev.clock() + horizon
            while self._pending and self._pending[0].t <= limit:
                d = self._pending.pop(0)
                dev.clock.advance_to(d.t)
                self._rx += d.data
        else:
            now = dev.clock()
            while self._pending and self._pending[0].t <= now:
                self._rx += self._pending.pop(0).data

    @property
    def in_waiting(self) -> int:
        """Bytes ready to read."""
        self._check()
        self._deliver(0.0)
        return len(self._rx)

    def read(self, size: int = 1) -> bytes:
        """Read up to ``size`` bytes, waiting at most the port timeout."""
        dev = self._check()
        timeout = self._timeout
        end = None if timeout is None else time.monotonic() + timeout
        while True:
            self._deliver(timeout or 0.0)
            if len(self._rx) >= size:
                break
            now = time.monotonic()
            if end is not None and now >= end:
                break
            if dev.opts.fast and timeout is not None:
                dev.clock.advance(timeout)  # the host waited its whole timeout
                break
            wake = self._pending[0].t - dev.clock() if self._pending else 0.05
            if end is not None:
                wake = min(wake, end - now)
            time.sleep(min(max(wake, 0.0), 0.05))
            dev = self._check()
        data = bytes(self._rx[:size])
        del self._rx[:size]
        return data

    def write(self, data: Any) -> int:
        """Send bytes to the robot."""
        dev = self._check()
        b = bytes(data)
        with _LOCK:
            self._pending.extend(dev.link.receive(b, dev.clock()))
        return len(b)

    def reset_input_buffer(self) -> None:
        """Discard bytes already received."""
        self._check()
        self._deliver(0.0)
        self._rx.clear()

    def reset_output_buffer(self) -> None:
        """Nothing is buffered on the way out."""
        self._check()

    def cancel_read(self) -> None:
        """Not supported; reads end at their timeout."""

    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
