"""Exceptions raised by the Nomad 200 driver.

The tree::

    NomadError
     +-- NomadTimeout (also TimeoutError)       no (complete) reply in time
     +-- NomadNak                                the robot answered NAK (type 8)
     +-- NomadProtocolError (also ValueError)    a reply that cannot be decoded
     |    +-- FrameError                         damaged framing in a byte stream
     |    |    +-- GarbageError                  bytes before a start byte
     |    |    +-- LengthError                   impossible length field
     |    |    +-- ChecksumError                 checksum mismatch
     |    |    +-- EndByteError                  end byte is not 0x5C
     |    |    +-- TruncatedPacketError          the stream ended inside a packet
     |    +-- PayloadError                       a well framed packet with a bad payload
     +-- NomadDisconnected (also ConnectionError) the port went away or is closed
     +-- NomadPortBusy                           another process holds the port lock

Errors coming from pyserial or the OS are re-raised as one of these with
``raise ... from err``. Errors of a command exchange say which command failed
(:attr:`NomadError.command`) and whether the robot executed it
(:attr:`NomadError.executed`): ``False`` after a NAK (the robot refuses a damaged or invalid
packet without acting on it), ``None`` when unknown (no or a damaged reply: the request or
the reply may have been lost).
"""

from __future__ import annotations

__all__ = [
    "ChecksumError",
    "EndByteError",
    "FrameError",
    "GarbageError",
    "LengthError",
    "NomadDisconnected",
    "NomadError",
    "NomadNak",
    "NomadPortBusy",
    "NomadProtocolError",
    "NomadTimeout",
    "PayloadError",
    "TruncatedPacketError",
]


class NomadError(Exception):
    """Root of every error raised by :mod:`nomad200`.

    Attributes
    ----------
    command : str or None
        Name of the command whose exchange failed (``"PR"``), if any.
    executed : bool or None
        ``False`` when the robot surely did not act on the command (it answered NAK),
        ``None`` when nobody knows.
    """

    command: str | None = None
    executed: bool | None = None


class NomadTimeout(NomadError, TimeoutError):
    """The robot did not answer (completely) within the command's timeout."""


class NomadNak(NomadError):
    """The robot refused the packet (NAK reply)."""


class NomadProtocolError(NomadError, ValueError):
    """A reply or stream that does not follow the protocol."""


class PayloadError(NomadProtocolError):
    """A correctly framed packet whose payload does not fit its type or the mask."""


class FrameError(NomadProtocolError):
    """Damaged framing found in a byte stream.

    Parameters
    ----------
    message : str
        Human readable description.
    offset : int
        Position of the damage in the decoder's stream (bytes fed so far).
    skipped : int
        Number of bytes the decoder discarded because of this error.
    """

    def __init__(self, message: str, *, offset: int = 0, skipped: int = 0) -> None:
        super().__init__(message)
        self.offset = offset
        self.skipped = skipped


class GarbageError(FrameError):
    """Bytes that are not a start byte (0x01) where a packet should begin."""


class LengthError(FrameError):
    """A length field that no packet can have."""


class ChecksumError(FrameError):
    """The checksum byte does not match the sum of the packet's bytes."""


class EndByteError(FrameError):
    """The byte after the checksum is not the end byte 0x5C."""


class TruncatedPacketError(FrameError):
    """The stream stopped (timeout or end) in the middle of a packet."""


class NomadDisconnected(NomadError, ConnectionError):
    """The serial port disappeared, failed, or is not open."""


class NomadPortBusy(NomadError):
    """The port is locked by another process (exclusive access)."""
