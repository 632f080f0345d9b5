"""The Nomad 200 host link: one request, one reply, over a serial port or a pyserial URL.

:class:`Link` opens its port with :func:`serial.serial_for_url`, so ``port`` may be a device
path (``/dev/ttyUSB0``), a pyserial URL such as ``spy:///dev/ttyUSB0`` (hex trace of the
traffic) or the emulator's ``nomad://?world=...`` scheme (importing :mod:`nomad200`
registers it). Every command is one request and one reply (the robot's strict protocol);
the input is flushed before each request, replies of the wrong type are dropped, and
damaged bytes are skipped by a resynchronising decoder.

Idempotent commands (GS, GET_SN, GET_RC, GET_RV and the setters CT, CONF_SN, CONF_TM, AC,
SP, DP, DA, VM, ST, LP) are retried up to ``retries`` times after a timeout, a damaged reply
or a NAK; PR, PA, MV, ZR and WS are never retried. Damage on the way TO the robot shows up
as a NAK (the robot refused a packet with a bad checksum or end byte and did nothing) or as
a timeout (the robot never saw a whole packet); damage on the way back as a damaged reply or
a timeout. A failed exchange raises a :class:`~nomad200.errors.NomadError` whose message
names the command and says whether the robot may have executed it (also in its
``command`` and ``executed`` attributes); the caller of a non-idempotent command decides
(e.g. reads the state and commands again).

Counters are plain attributes; ``counters()`` returns them as a dict for logging. Every
exchange (``requests``) ends in exactly one of ``replies``, ``naks``, ``timeouts``,
``frame_errors`` (a reply that arrived damaged or incomplete) or a lost port; ``retry_count``
counts the repeated exchanges among them. ``skipped_bytes`` and ``stale_packets`` count
received bytes and packets that were thrown away. The commands themselves, in SI units,
are :class:`nomad200.client.Client`'s.
"""

from __future__ import annotations

import logging
import math
import threading
import time
import weakref
from types import TracebackType
from typing import Any, Final, TypeVar

import serial

try:  # a hung-up pty makes termios calls (tcflush) fail with termios.error
    from termios import error as _TermiosError
except ImportError:  # pragma: no cover - not POSIX
    _TermiosError = OSError  # type: ignore[assignment,misc]

from nomad200.codec import Cmd, Packet, encode_command
from nomad200.errors import (
    FrameError,
    NomadDisconnected,
    NomadError,
    NomadNak,
    NomadPortBusy,
    NomadProtocolError,
    NomadTimeout,
    TruncatedPacketError,
)
from nomad200.stream import StreamDecoder

__all__ = ["Link", "open_clients"]

logger = logging.getLogger(__name__)

_LinkT = TypeVar("_LinkT", bound="Link")

ZR_TIMEOUT: Final = 120.0
_IDEMPOTENT: Final = frozenset(
    {
        Cmd.GS,
        Cmd.GET_SN,
        Cmd.GET_RC,
        Cmd.GET_RV,
        Cmd.CT,
        Cmd.CONF_SN,
        Cmd.CONF_TM,
        Cmd.AC,
        Cmd.SP,
        Cmd.DP,
        Cmd.DA,
        Cmd.VM,
        Cmd.ST,
        Cmd.LP,
    }
)
_OPEN: weakref.WeakSet[Link] = weakref.WeakSet()


def open_clients() -> list[Link]:
    """Links (clients) whose port is open (for leak checks in tests)."""
    return [c for c in _OPEN if c.is_open]


class Link:
    """The serial link to a Nomad 200: opening, locking, exchanges, retries and counters.

    Parameters
    ----------
    port : str
        Device path or pyserial URL.
    baud : int
        4800, 9600, 19200 or 38400 on a real robot.
    timeout : float
        Reply timeout in seconds for ordinary commands (ZR gets 120 s, WS its own + 1 s).
    retries : int
        Extra attempts for idempotent commands.
    exclusive : bool
        Lock the port (pyserial ``exclusive=True``: an ``flock`` on device files and ptys,
        the emulator URL refuses a second open).
    """

    def __init__(
        self,
        port: str,
        *,
        baud: int = 9600,
        timeout: float = 1.0,
        retries: int = 2,
        exclusive: bool = True,
    ) -> None:
        self.port = port
        self.baud = baud
        self.timeout = timeout
        self.retries = retries
        self.exclusive = exclusive
        self._ser: Any = None
        self._io_timeout: float | None = None
        self._lock = threading.RLock()
        self._decoder = StreamDecoder()
        self.requests = 0
        self.replies = 0
        self.retry_count = 0
        self.timeouts = 0
        self.naks = 0
        self.frame_errors = 0
        self.stale_packets = 0
        self.reconnects = 0
        self._skipped_before = 0

    # ------------------------------------------------------------ port handling
    @property
    def is_open(self) -> bool:
        """Whether the serial port is open."""
        return self._ser is not None

    @property
    def skipped_bytes(self) -> int:
        """Received bytes discarded as garbage, damaged or stale (all time)."""
        return self._skipped_before + self._decoder.skipped_bytes

    def counters(self) -> dict[str, int]:
        """All counters as a dict."""
        return {
            "requests": self.requests,
            "replies": self.replies,
            "retries": self.retry_count,
            "timeouts": self.timeouts,
            "naks": self.naks,
            "frame_errors": self.frame_errors,
            "skipped_bytes": self.skipped_bytes,
            "stale_packets": self.stale_packets,
            "reconnects": self.reconnects,
        }

    def open(self) -> None:
        """Open (and lock) the port, then run :meth:`_on_open` (a subclass's handshake).

        Raises
        ------
        NomadPortBusy
            Another process holds the port.
        NomadDisconnected
            The port does not exist or cannot be opened.
        NomadTimeout, NomadProtocolError
            The port opened but the robot did not answer the mask (the port is closed again).
        """
        with self._lock:
            if self._ser is not None:
                return
            try:
                self._ser = serial.serial_for_url(
                    self.port,
                    baudrate=self.baud,
                    timeout=self.timeout,
                    write_timeout=self.timeout,
                    exclusive=self.exclusive,
                )
            except serial.SerialException as err:
                if "lock" in str(err).lower() or "busy" in str(err).lower():
                    raise NomadPortBusy(f"{self.port}: port is in use ({err})") from err
                raise NomadDisconnected(f"{self.port}: cannot open ({err})") from err
            except (OSError, ValueError) as err:
                raise NomadDisconnected(f"{self.port}: cannot open ({err})") from err
            self._io_timeout = self.timeout
            _OPEN.add(self)
            try:
                self._on_open()
            except NomadError:
                self._drop_port()
                raise

    def _on_open(self) -> None:
        """Called with the port just opened; a failure closes it again. Nothing here."""

    def close(self) -> None:
        """Close the port (idempotent)."""
        with self._lock:
            self._drop_port()

    def __enter__(self: _LinkT) -> _LinkT:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def reconnect(self, deadline_s: float = 30.0) -> None:
        """Close and reopen the port, retrying with backoff for up to ``deadline_s`` seconds.

        Raises
        ------
        NomadDisconnected
            The port did not come back in time (chained to the last error).
        """
        with self._lock:
            self._drop_port()
            end = time.monotonic() + deadline_s
            delay = 0.05
            while True:
                try:
                    self.open()
                except NomadError as err:
                    last: NomadError = err
                else:
                    self.reconnects += 1
                    logger.info("reconnected to %s", self.port)
                    return
                if time.monotonic() + delay > end:
                    raise NomadDisconnected(
                        f"{self.port}: not back within {deadline_s:g} s ({last})"
                    ) from last
                time.sleep(delay)
                delay = min(delay * 2, 1.0)

    def _drop_port(self) -> None:
        ser, self._ser = self._ser, None
        _OPEN.discard(self)
        if ser is not None:
            try:
                ser.close()
            except (OSError, serial.SerialException) as err:  # pragma: no cover - best effort
                logger.debug("closing %s: %s", self.port, err)

    # ------------------------------------------------------------ transactions
    def _transact(self, code: Cmd, args: tuple[int, ...], reply_len: int, timeout: float) -> Packet:
        frame = encode_command(code, *args)
        idempotent = code in _IDEMPOTENT
        attempts = 1 + (self.retries if idempotent else 0)
        with self._lock:
            last: NomadError | None = None
            for attempt in range(attempts):
                if attempt:
                    self.retry_count += 1
                    logger.debug("retry %d of %s after %s", attempt, code.name, last)
                try:
                    return self._exchange(frame, code, reply_len, timeout)
                except (NomadTimeout, NomadProtocolError, NomadNak) as err:
                    last = err
                except NomadError as err:  # the port is gone: no retry
                    err.command = code.name
                    raise
            assert last is not None
            last.command = code.name
            last.executed = False if isinstance(last, NomadNak) else None
            if isinstance(last, NomadNak):
                note = "the robot did not execute it"
            elif idempotent:
                note = "no good reply"
            else:
                note = "the robot may or may not have executed it"
            if idempotent:
                note += f" after {attempts} attempt(s)"
            else:
                note += f"; {code.name} is not idempotent and was not retried"
            last.args = (f"{last.args[0] if last.args else ''} ({note})", *last.args[1:])
            raise last

    def _exchange(self, frame: bytes, code: Cmd, reply_len: int, timeout: float) -> Packet:
        """One request and its reply; counts exactly one outcome unless the port is lost."""
        ser = self._ser
        if ser is None:
            raise NomadDisconnected(f"{self.port}: not open")
        dec = self._decoder
        dec.accept_lengths = (reply_len, 2)
        self.requests += 1
        last_err: FrameError | None = None
        try:
            ser.reset_input_buffer()
            dec.reset()
            ser.write(frame)
            deadline = time.monotonic() + timeout
            received = 0
            while True:
                need = dec.needed()
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                if received:
                    # a reply that has begun arrives at line speed: a lost byte must not
                    # cost the whole command timeout (no timeout change, which costs a
                    # tcsetattr, when the bytes are already there)
                    io = min(self._rest_timeout(need), remaining)
                    if self._io_timeout is not None and ser.in_waiting >= need:
                        io = self._io_timeout
                else:
                    io = timeout if remaining > 0.5 * timeout else remaining
                if io != self._io_timeout:
                    ser.timeout = io
                    self._io_timeout = io
                data = ser.read(need)
                received += len(data)
                if data:
                    for ev in dec.feed(data):
                        if isinstance(ev, FrameError):
                            last_err = ev
                        elif ev.type == code:
                            self.replies += 1
                            return ev
                        elif ev.type == Cmd.NAK:
                            self.naks += 1
                            raise NomadNak(f"robot refused {code.name} (NAK)")
                        else:
                            self.stale_packets += 1
                if len(data) < need:
                    break  # pyserial returns short reads only when its timeout expired
                if last_err is not None and not dec.pending and received >= reply_len + 4:
                    break  # the whole reply came, damaged: do not wait for the timeout
        except NomadError:
            raise
        except serial.SerialTimeoutException as err:
            self.timeouts += 1
            raise NomadTimeout(f"{self.port}: write of {code.name} timed out") from err
        except (serial.SerialException, OSError, _TermiosError, TypeError, AttributeError) as err:
            # pyserial raises TypeError/AttributeError when the fd vanished under it
            self._drop_port()
            raise NomadDisconnected(f"{self.port}: {err}") from err
        trunc = dec.flush()
        if trunc is not None:
            self.frame_errors += 1
            raise TruncatedPacketError(
                f"{code.name}: incomplete reply ({trunc})",
                offset=trunc.offset,
                skipped=trunc.skipped,
            ) from trunc
        if last_err is not None:
            self.frame_errors += 1
            raise NomadProtocolError(f"{code.name}: damaged reply ({last_err})") from last_err
        self.timeouts += 1
        raise NomadTimeout(f"{self.port}: no reply to {code.name} within {timeout:g} s")

    def _rest_timeout(self, need: int) -> float:
        """Time allowed for the rest of a reply that has started (10 bits per byte, x2)."""
        return math.ceil((0.05 + 20.0 * need / self.baud) * 100.0) / 100.0
