"""Nomad 200 host-link packets: frames, integers and command payloads (bytes only, no I/O).

A packet on the wire is ``0x01 | len_lo | len_hi | type | payload | checksum | 0x5C`` where
``len`` counts type, payload and checksum, and the checksum is the sum of every byte from
the 0x01 through the last payload byte, modulo 256.

Signed integers are little-endian *sign-magnitude*: 16-bit ones hold at most +/-32767.

Examples
--------
>>> encode_frame(Cmd.GS).hex(" ")
'01 02 00 07 0a 5c'
>>> decode_frame(encode_command(Cmd.PR, 100, -450, 0))
Packet(type=3, payload=b'd\\x00\\xc2\\x81\\x00\\x00')
>>> decode_command(decode_frame(encode_command(Cmd.PR, 100, -450, 0)))
Command(code=<Cmd.PR: 3>, args=(100, -450, 0))
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass
from typing import Final, Literal, NamedTuple, get_args

from nomad200.errors import (
    ChecksumError,
    EndByteError,
    GarbageError,
    LengthError,
    PayloadError,
    TruncatedPacketError,
)

__all__ = [
    "BAUD_RATES",
    "END",
    "MAX_LENGTH",
    "START",
    "BaudRate",
    "Cmd",
    "Command",
    "MvMode",
    "Packet",
    "checksum",
    "decode_command",
    "decode_frame",
    "encode_command",
    "encode_frame",
    "from_sm16",
    "from_sm32",
    "to_sm16",
    "to_sm32",
]

#: A line speed the robot's serial port supports (8N1, no flow control).
BaudRate = Literal[4800, 9600, 19200, 38400]
#: Every supported line speed, slowest first (Ndirect falls back to 38400 for others).
BAUD_RATES: Final[tuple[int, ...]] = get_args(BaudRate)
START: Final = 0x01
END: Final = 0x5C
#: Largest ``len`` field the decoders accept (a full state reply with every attachment is
#: well under 1 kB).
MAX_LENGTH: Final = 2048


class Cmd(enum.IntEnum):
    """Command (and reply) type codes."""

    AC = 1
    SP = 2
    PR = 3
    PA = 4
    VM = 5
    CT = 6
    GS = 7
    NAK = 8
    ST = 9
    LP = 10
    TK = 11
    DP = 12
    ZR = 13
    CONF_IR = 14
    CONF_SN = 15
    CONF_CP = 16
    CONF_LS = 17
    CONF_TM = 18
    GET_IR = 19
    GET_SN = 20
    GET_RC = 21
    GET_RV = 22
    GET_RA = 23
    GET_CP = 24
    GET_LS = 25
    SETUP_LS = 26
    GET_BP = 27
    CONF_SG = 28
    GET_SG = 29
    DA = 30
    WS = 31
    CONF_SER = 35
    MV = 43
    SPECIAL = 128


class MvMode(enum.IntEnum):
    """Per-axis modes of the MV command."""

    IGNORE = 0
    VM = 1
    PR = 2
    LP = 3
    AC = 4
    SP = 5
    PA = 6


class Packet(NamedTuple):
    """A decoded frame: its type byte and the payload between type and checksum."""

    type: int
    payload: bytes


@dataclass(frozen=True, slots=True)
class Command:
    """A host-to-robot command as integers in robot units."""

    code: Cmd
    args: tuple[int, ...] = ()


# ---------------------------------------------------------------- integers


def to_sm16(n: int) -> int:
    """Return the 16-bit sign-magnitude pattern of ``n`` (|n| <= 32767)."""
    if not -32767 <= n <= 32767:
        raise ValueError(f"{n} does not fit a 16-bit sign-magnitude integer (+/-32767)")
    return (-n) | 0x8000 if n < 0 else n


def from_sm16(u: int) -> int:
    """Return the integer held by the 16-bit sign-magnitude pattern ``u``."""
    return -(u & 0x7FFF) if u & 0x8000 else u


def to_sm32(n: int) -> int:
    """Return the 32-bit sign-magnitude pattern of ``n`` (|n| < 2**31)."""
    if not -0x7FFFFFFF <= n <= 0x7FFFFFFF:
        raise ValueError(f"{n} does not fit a 32-bit sign-magnitude integer")
    return (-n) | 0x80000000 if n < 0 else n


def from_sm32(u: int) -> int:
    """Return the integer held by the 32-bit sign-magnitude pattern ``u``."""
    return -(u & 0x7FFFFFFF) if u & 0x80000000 else u


# ---------------------------------------------------------------- frames


def checksum(data: bytes | bytearray | memoryview) -> int:
    """Sum of ``data`` modulo 256 (pass the frame from 0x01 through the last payload byte)."""
    return sum(data) & 0xFF


def encode_frame(ptype: int, payload: bytes = b"") -> bytes:
    """Frame ``payload`` as a packet of type ``ptype``.

    Parameters
    ----------
    ptype : int
        The type byte (a :class:`Cmd` value).
    payload : bytes
        Bytes between the type byte and the checksum.

    Returns
    -------
    bytes
        ``0x01 len_lo len_hi type payload checksum 0x5C``.
    """
    n = len(payload) + 2
    if n > 0xFFFF:
        raise ValueError(f"payload of {len(payload)} bytes is too long for one packet")
    head = bytes((START, n & 0xFF, n >> 8, ptype))
    return head + payload + bytes((((sum(head) + sum(payload)) & 0xFF), END))


def decode_frame(frame: bytes | bytearray | memoryview) -> Packet:
    """Decode exactly one complete frame.

    Raises
    ------
    GarbageError, LengthError, ChecksumError, EndByteError, TruncatedPacketError
        For the first defect found; use :class:`nomad200.stream.StreamDecoder` to read a
        stream that may hold damage.
    """
    buf = bytes(frame)
    if not buf or buf[0] != START:
        raise GarbageError(f"expected start byte 0x01, got {buf[:1].hex() or 'nothing'}")
    if len(buf) < 3:
        raise TruncatedPacketError(f"frame of {len(buf)} bytes has no length field")
    n = buf[1] | (buf[2] << 8)
    if n < 2 or n > MAX_LENGTH:
        raise LengthError(f"length field {n} outside 2..{MAX_LENGTH}")
    if len(buf) < n + 4:
        raise TruncatedPacketError(f"frame holds {len(buf)} of {n + 4} bytes")
    if len(buf) > n + 4:
        raise LengthError(f"{len(buf) - n - 4} bytes after the end of a {n + 4}-byte frame")
    want = sum(buf[: n + 2]) & 0xFF
    if buf[n + 2] != want:
        raise ChecksumError(f"checksum 0x{buf[n + 2]:02x}, expected 0x{want:02x}")
    if buf[n + 3] != END:
        raise EndByteError(f"end byte 0x{buf[n + 3]:02x}, expected 0x5c")
    return Packet(buf[3], buf[4 : n + 2])


# ---------------------------------------------------------------- commands

# code -> (struct format of the payload, indices of sign-magnitude 16-bit args)
_CMD_FORMATS: dict[Cmd, tuple[str, tuple[int, ...]]] = {
    Cmd.AC: ("<HHH", ()),
    Cmd.SP: ("<HHH", ()),
    Cmd.PR: ("<HHH", (0, 1, 2)),
    Cmd.PA: ("<HHH", (0, 1, 2)),
    Cmd.VM: ("<HHH", (0, 1, 2)),
    Cmd.MV: ("<HHHHHH", (1, 3, 5)),
    Cmd.CT: ("<7B", ()),
    Cmd.GS: ("<", ()),
    Cmd.ST: ("<", ()),
    Cmd.LP: ("<", ()),
    Cmd.ZR: ("<", ()),
    Cmd.DP: ("<HH", (0, 1)),
    Cmd.DA: ("<HH", (0, 1)),
    Cmd.WS: ("<4B", ()),
    Cmd.CONF_SN: ("<17B", ()),
    Cmd.CONF_TM: ("<B", ()),
    Cmd.GET_SN: ("<", ()),
    Cmd.GET_RC: ("<", ()),
    Cmd.GET_RV: ("<", ()),
}
_CMD_STRUCTS: dict[int, tuple[Cmd, struct.Struct, tuple[int, ...]]] = {
    int(code): (code, struct.Struct(fmt), signed) for code, (fmt, signed) in _CMD_FORMATS.items()
}

#: Commands this codec can encode and decode.
SUPPORTED_COMMANDS: Final = frozenset(_CMD_FORMATS)


def encode_command(code: Cmd, *args: int) -> bytes:
    """Encode a command frame from integer arguments in robot units.

    Parameters
    ----------
    code : Cmd
        One of :data:`SUPPORTED_COMMANDS`.
    *args : int
        The payload values in order: AC/SP three unsigned 16-bit; PR/PA/VM three signed;
        MV mode, value, mode, value, mode, value; CT seven mask bytes; DP/DA two signed;
        WS trans, steer, turret flags and a timeout byte; CONF_SN rate and 16 order bytes;
        CONF_TM one byte.

    Returns
    -------
    bytes
        The complete frame.
    """
    try:
        _, st, signed = _CMD_STRUCTS[int(code)]
    except KeyError:
        raise ValueError(f"command {code!r} is not supported by this codec") from None
    vals = list(args)
    for i in signed:
        vals[i] = to_sm16(vals[i])
    try:
        payload = st.pack(*vals)
    except struct.error as err:
        raise ValueError(f"bad arguments {args!r} for {Cmd(code).name}: {err}") from err
    return encode_frame(int(code), payload)


def decode_command(packet: Packet) -> Command:
    """Decode a command packet's payload into a :class:`Command`.

    Raises
    ------
    PayloadError
        Unknown command type or a payload of the wrong length.
    """
    try:
        code, st, signed = _CMD_STRUCTS[packet.type]
    except KeyError:
        raise PayloadError(f"unsupported command type {packet.type}") from None
    if len(packet.payload) != st.size:
        raise PayloadError(
            f"{code.name} payload has {len(packet.payload)} bytes, expected {st.size}"
        )
    vals = st.unpack(packet.payload)
    if signed:
        lst = list(vals)
        for i in signed:
            lst[i] = from_sm16(lst[i])
        vals = tuple(lst)
    return Command(code, vals)
