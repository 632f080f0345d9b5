"""Serial-line timing and fault injection between a transport and the device model.

The :class:`Link` turns "the host wrote these bytes at time t" into "these reply bytes are
fully on the host's side at time t'": a byte takes 10 bit times (8N1) in each direction,
the two directions are separate wires, and the robot answers when the request's last byte
has arrived. :class:`Faults` then damages replies: dropped bytes, garbled bytes, stalls.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from nomad200.emulator.model import NomadModel

__all__ = ["Delivery", "Faults", "Link"]


@dataclass
class Faults:
    """Reply damage, all seeded.

    Parameters
    ----------
    garble : float
        Probability that a reply byte is replaced by a different random byte.
    drop : float
        Probability that a reply byte is lost.
    stall : float
        Probability that a reply is held back by ``stall_s`` seconds.
    stall_s : float
        Length of a stall (make it longer than the client's timeout to test timeouts).
    seed : int
        Seed of the random generator.
    """

    garble: float = 0.0
    drop: float = 0.0
    stall: float = 0.0
    stall_s: float = 2.0
    seed: int = 0
    rng: np.random.Generator = field(init=False, repr=False)
    garbled_bytes: int = 0
    dropped_bytes: int = 0
    stalls: int = 0

    def __post_init__(self) -> None:
        for name in ("garble", "drop", "stall"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name} rate must be within 0..1, got {p}")
        if self.stall_s < 0:
            raise ValueError(f"stall duration must be >= 0, got {self.stall_s}")
        self.rng = np.random.default_rng(self.seed)

    @property
    def active(self) -> bool:
        """Whether any fault is enabled."""
        return bool(self.garble or self.drop or self.stall)

    def apply(self, data: bytes) -> tuple[bytes, float]:
        """Damage one reply; return the bytes to send and the extra delay (s)."""
        if not self.active:
            return data, 0.0
        rng = self.rng
        arr = np.frombuffer(data, dtype=np.uint8).copy()
        if self.garble:
            hit = rng.random(arr.size) < self.garble
            if hit.any():
                arr[hit] ^= rng.integers(1, 256, int(hit.sum()), dtype=np.uint8)
                self.garbled_bytes += int(hit.sum())
        if self.drop:
            keep = rng.random(arr.size) >= self.drop
            self.dropped_bytes += int(arr.size - keep.sum())
            arr = arr[keep]
        delay = 0.0
        if self.stall and rng.random() < self.stall:
            self.stalls += 1
            delay = self.stall_s
        return arr.tobytes(), delay


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
        Damage applied to replies.
    """

    def __init__(self, model: NomadModel, *, baud: int = 9600, faults: Faults | None = None):
        if baud <= 0:
            raise ValueError(f"baud rate must be positive, got {baud}")
        self.model = model
        self.baud = baud
        self.byte_time = 10.0 / baud
        self.faults = faults or Faults()
        self._rx_free = -float("inf")
        self._tx_free = -float("inf")
        self.rx_bytes = 0
        self.tx_bytes = 0

    def receive(self, data: bytes, now: float) -> list[Delivery]:
        """Host bytes written at ``now``; return the replies they cause."""
        if not data:
            return []
        self.rx_bytes += len(data)
        done = max(now, self._rx_free) + len(data) * self.byte_time
        self._rx_free = done
        out = []
        for ready, frame in self.model.feed(data, t=done):
            wire, delay = self.faults.apply(frame)
            start = max(ready, self._tx_free)
            end = start + len(frame) * self.byte_time + delay
            self._tx_free = end  # a stall holds back everything behind it
            self.tx_bytes += len(wire)
            out.append(Delivery(end, wire, delay > 0))
        return out
