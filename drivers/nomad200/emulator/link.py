"""Serial-line timing and fault injection between a transport and the device model.

The :class:`Link` turns "the host wrote these bytes at time t" into "these reply bytes are
fully on the host's side at time t'": a byte takes 10 bit times (8N1) in each direction,
the two directions are separate wires, and the robot answers when the request's last byte
has arrived. :class:`Faults` damages both directions: replies (robot to host: dropped and
garbled bytes, stalls) and requests (host to robot, the ``_rx`` rates: dropped and garbled
bytes, which the robot's parser answers with a NAK or not at all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from nomad200.emulator.model import NomadModel

__all__ = ["Delivery", "Faults", "Link"]

_RATES = ("garble", "drop", "stall", "garble_rx", "drop_rx")


def _damage(
    rng: np.random.Generator, data: bytes, garble: float, drop: float
) -> tuple[bytes, int, int]:
    """Garble then drop bytes of ``data``; return (bytes, how many garbled, how many lost)."""
    arr = np.frombuffer(data, dtype=np.uint8).copy()
    garbled = dropped = 0
    if garble:
        hit = rng.random(arr.size) < garble
        garbled = int(hit.sum())
        if garbled:
            arr[hit] ^= rng.integers(1, 256, garbled, dtype=np.uint8)
    if drop:
        keep = rng.random(arr.size) >= drop
        dropped = int(arr.size - keep.sum())
        arr = arr[keep]
    return arr.tobytes(), garbled, dropped


@dataclass
class Faults:
    """Line damage in both directions, all seeded.

    Parameters
    ----------
    garble : float
        Probability that a reply byte (robot to host) is replaced by a different byte.
    drop : float
        Probability that a reply byte is lost.
    stall : float
        Probability that a reply is held back by ``stall_s`` seconds.
    stall_s : float
        Length of a stall (make it longer than the client's timeout to test timeouts).
    seed : int
        Seed of the random generators (one per direction, so enabling request damage
        leaves the reply damage of a seed unchanged).
    garble_rx : float
        Probability that a request byte (host to robot) is replaced by a different byte.
    drop_rx : float
        Probability that a request byte is lost.
    """

    garble: float = 0.0
    drop: float = 0.0
    stall: float = 0.0
    stall_s: float = 2.0
    seed: int = 0
    garble_rx: float = 0.0
    drop_rx: float = 0.0
    rng: np.random.Generator = field(init=False, repr=False)
    rng_rx: np.random.Generator = field(init=False, repr=False)
    garbled_bytes: int = 0
    dropped_bytes: int = 0
    stalls: int = 0
    garbled_rx_bytes: int = 0
    dropped_rx_bytes: int = 0

    def __post_init__(self) -> None:
        for name in _RATES:
            p = getattr(self, name)
            if not (math.isfinite(p) and 0.0 <= p <= 1.0):
                raise ValueError(f"{name} rate must be within 0..1, got {p}")
        if self.stall_s < 0:
            raise ValueError(f"stall duration must be >= 0, got {self.stall_s}")
        self.rng = np.random.default_rng(self.seed)
        self.rng_rx = np.random.default_rng([self.seed, 1])

    @property
    def active(self) -> bool:
        """Whether any reply fault is enabled."""
        return bool(self.garble or self.drop or self.stall)

    @property
    def active_rx(self) -> bool:
        """Whether any request fault is enabled."""
        return bool(self.garble_rx or self.drop_rx)

    def apply(self, data: bytes) -> tuple[bytes, float]:
        """Damage one reply; return the bytes to send and the extra delay (s)."""
        if not self.active:
            return data, 0.0
        out, garbled, dropped = _damage(self.rng, data, self.garble, self.drop)
        self.garbled_bytes += garbled
        self.dropped_bytes += dropped
        delay = 0.0
        if self.stall and self.rng.random() < self.stall:
            self.stalls += 1
            delay = self.stall_s
        return out, delay

    def apply_rx(self, data: bytes) -> bytes:
        """Damage bytes on their way from the host to the robot; return what arrives."""
        if not self.active_rx:
            return data
        out, garbled, dropped = _damage(self.rng_rx, data, self.garble_rx, self.drop_rx)
        self.garbled_rx_bytes += garbled
        self.dropped_rx_bytes += dropped
        return out


class Delivery(NamedTuple):
    """Reply bytes and the time their last byte reaches the host."""

    t: float
    data: bytes
    stalled: bool


class Link:
    """Timing of one serial line around a :class:`NomadModel`.

    Parameters
    ----------
    model : NomadModel
        The device; its clock is the link's clock.
    baud : int
        Bits per second (10 bits per byte).
    faults : Faults, optional
        Damage applied to requests and replies.
    """

    def __init__(self, model: NomadModel, *, baud: int = 9600, faults: Faults | None = None):
        if baud <= 0:
            raise ValueError(f"baud rate must be positive, got {baud}")
        self.model = model
        self.baud = baud
        self.byte_time = 10.0 / baud
        self.faults = faults or Faults()
        self._rx_free = -float("inf")
        self._rx_heard = -float("inf")
        self._tx_free = -float("inf")
        self.rx_bytes = 0
        self.tx_bytes = 0

    def receive(self, data: bytes, now: float, *, quiet: float | None = None) -> list[Delivery]:
        """Host bytes written at ``now``; return the replies they cause.

        Parameters
        ----------
        data : bytes
            What the host wrote (request faults are applied here).
        now : float
            Link-clock time of the write.
        quiet : float, optional
            How long the transport saw the line silent before these bytes (a pty server in
            fast mode measures it in real time while its clock is virtual); the robot's
            parser gets the longer of this and the silence on the link clock.
        """
        if not data:
            return []
        self.rx_bytes += len(data)
        start = max(now, self._rx_free)
        done = start + len(data) * self.byte_time
        self._rx_free = done
        wire = self.faults.apply_rx(data)
        if not wire:
            return []  # every byte lost: the robot heard nothing
        silent = start - self._rx_heard
        if quiet is not None:
            silent = max(silent, quiet)
        self._rx_heard = done
        out = []
        for ready, frame in self.model.feed(wire, t=done, quiet=silent):
            wire_tx, delay = self.faults.apply(frame)
            t0 = max(ready, self._tx_free)
            end = t0 + len(frame) * self.byte_time + delay
            self._tx_free = end  # a stall holds back everything behind it
            self.tx_bytes += len(wire_tx)
            out.append(Delivery(end, wire_tx, delay > 0))
        return out
