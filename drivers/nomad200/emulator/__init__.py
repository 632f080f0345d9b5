"""The emulated Nomad 200: a device model (bytes in, bytes out) and its transports.

- :class:`~nomad200.emulator.model.NomadModel`: the robot's state machine, transport-free;
  it reads host packets with :class:`~nomad200.emulator.rx.HostParser` (NAK, inter-byte
  timeout) and runs :class:`~nomad200.emulator.robot.Robot` (clock, drive, sonar firings,
  watchdog) between them.
- :class:`~nomad200.emulator.link.Link`: serial timing (10 bits per byte) and fault injection
  in both directions.
- :mod:`nomad200.protocol_nomad`: the ``nomad://`` pyserial URL scheme (in-process).
- :class:`~nomad200.emulator.pty_server.PtyServer`: a real pseudo-terminal
  (``nomad-emulator`` command).
"""

from nomad200.emulator.clock import MonotonicClock, VirtualClock
from nomad200.emulator.link import Faults, Link
from nomad200.emulator.model import NomadModel

__all__ = ["Faults", "Link", "MonotonicClock", "NomadModel", "VirtualClock"]
