"""The robot's receiver: how the emulated Nomad 200 parses host packets off its line.

The host's :class:`~nomad200.stream.StreamDecoder` rescans damaged bytes for a packet hidden
inside them. The robot's parser is a small firmware state machine instead:

1. hunt for the start byte 0x01 (anything else is ignored);
2. read the two length bytes; a length outside ``2..max_length`` (host packets stay under
   256 bytes) means that 0x01 was no start byte: hunt again from the byte after it;
3. read the rest of the packet (``len + 1`` bytes: type, payload, checksum, end byte) and
   check the checksum and the end byte. A mismatch costs one NAK and the packet's bytes are
   gone (never rescanned), so one damaged packet gives exactly one NAK;
4. an incomplete packet is discarded silently when the line has been quiet for longer than
   the inter-byte timeout before the next bytes come: a dropped byte costs that one packet
   (no reply, the host times out) and the host's next packet parses cleanly.

Examples
--------
>>> from nomad200.codec import Cmd, encode_frame
>>> rx = HostParser()
>>> gs = encode_frame(Cmd.GS)
>>> bad = bytearray(gs); bad[3] ^= 0x40              # garbled type byte
>>> [type(e).__name__ for e in rx.feed(b"zz" + bytes(bad) + gs)]
['GarbageError', 'ChecksumError', 'Packet']
>>> rx.feed(gs[:4] + gs[5:])                          # a dropped checksum: waits
[]
>>> [type(e).__name__ for e in rx.feed(gs, quiet=0.5)]  # the line was quiet: resync
['TruncatedPacketError', 'Packet']
"""

from __future__ import annotations

from typing import Final

from nomad200.codec import END, START, Packet
from nomad200.errors import (
    ChecksumError,
    EndByteError,
    FrameError,
    GarbageError,
    LengthError,
    TruncatedPacketError,
)

__all__ = ["GAP_TIMEOUT", "MAX_HOST_LENGTH", "HostParser"]

#: Inter-byte timeout (s): a packet left incomplete for longer than this is dropped. The
#: host's reply timeout must be longer (the original host library waits 1 s).
GAP_TIMEOUT: Final = 0.1
#: Largest ``len`` field of a host packet (the whole packet stays under 256 bytes).
MAX_HOST_LENGTH: Final = 251

_START: Final = bytes((START,))


class HostParser:
    """Incremental parser of host-to-robot packets (the robot's side of the link).

    Parameters
    ----------
    gap_timeout : float
        Inter-byte timeout in seconds (see :meth:`feed`).
    max_length : int
        Largest acceptable ``len`` field.

    Attributes
    ----------
    packets : int
        Good packets parsed.
    bad_packets : int
        Complete packets with a wrong checksum or end byte (each one is NAKed).
    discarded : int
        Incomplete packets dropped by the inter-byte timeout.
    garbage_bytes : int
        Bytes ignored while hunting for a start byte (false starts included).
    """

    def __init__(
        self, *, gap_timeout: float = GAP_TIMEOUT, max_length: int = MAX_HOST_LENGTH
    ) -> None:
        self.gap_timeout = gap_timeout
        self.max_length = max_length
        self._buf = bytearray()
        self._length = 0  # len field of the packet in _buf (valid once _buf holds 3 bytes)
        self._offset = 0  # stream offset of _buf[0], or of the next byte when _buf is empty
        self.packets = 0
        self.bad_packets = 0
        self.discarded = 0
        self.garbage_bytes = 0

    @property
    def pending(self) -> int:
        """Bytes of an incomplete packet held."""
        return len(self._buf)

    def feed(
        self, data: bytes | bytearray | memoryview, *, quiet: float = 0.0
    ) -> list[Packet | FrameError]:
        """Parse bytes that arrived back to back after ``quiet`` seconds of silence.

        Returns the packets and framing errors in order (errors are returned, not raised):
        :class:`ChecksumError` / :class:`EndByteError` for a damaged packet (the robot
        NAKs it), :class:`TruncatedPacketError` for an incomplete packet dropped by the
        inter-byte timeout, :class:`GarbageError` / :class:`LengthError` for ignored bytes.
        """
        out: list[Packet | FrameError] = []
        buf = self._buf
        if buf and quiet > self.gap_timeout:
            n = len(buf)
            out.append(
                TruncatedPacketError(
                    f"packet of {n} byte(s) at stream offset {self._offset} not completed "
                    f"within {self.gap_timeout:g} s: dropped",
                    offset=self._offset,
                    skipped=n,
                )
            )
            self.discarded += 1
            self._offset += n
            buf.clear()
        src = bytes(data)
        pos = 0
        while pos < len(src):
            if not buf:
                j = src.find(_START, pos)
                end = len(src) if j < 0 else j
                if end > pos:
                    out.append(self._garbage(end - pos))
                    pos = end
                    continue
                buf.append(START)
                pos += 1
                continue
            if len(buf) < 3:
                take = min(3 - len(buf), len(src) - pos)
                buf += src[pos : pos + take]
                pos += take
                if len(buf) < 3:
                    break
                length = buf[1] | (buf[2] << 8)
                if not 2 <= length <= self.max_length:
                    # not a start byte after all: hunt again from the byte after it
                    out.append(
                        LengthError(
                            f"implausible length field {length} at stream offset "
                            f"{self._offset} (1 byte skipped)",
                            offset=self._offset,
                            skipped=1,
                        )
                    )
                    self.garbage_bytes += 1
                    src = bytes(buf[1:]) + src[pos:]
                    pos = 0
                    self._offset += 1
                    buf.clear()
                    continue
                self._length = length
            total = self._length + 4
            take = min(total - len(buf), len(src) - pos)
            buf += src[pos : pos + take]
            pos += take
            if len(buf) < total:
                break
            out.append(self._complete(bytes(buf)))
            self._offset += total
            buf.clear()
        return out

    def reset(self) -> int:
        """Drop an incomplete packet silently; return how many bytes it held."""
        n = len(self._buf)
        self._offset += n
        self._buf.clear()
        return n

    def _garbage(self, n: int) -> GarbageError:
        err = GarbageError(
            f"{n} byte(s) before a start byte at stream offset {self._offset}",
            offset=self._offset,
            skipped=n,
        )
        self.garbage_bytes += n
        self._offset += n
        return err

    def _complete(self, frame: bytes) -> Packet | FrameError:
        want = sum(frame[:-2]) & 0xFF
        at = self._offset
        n = len(frame)
        if frame[-2] != want:
            self.bad_packets += 1
            return ChecksumError(
                f"checksum 0x{frame[-2]:02x}, expected 0x{want:02x} in the {n}-byte packet "
                f"at stream offset {at}",
                offset=at,
                skipped=n,
            )
        if frame[-1] != END:
            self.bad_packets += 1
            return EndByteError(
                f"end byte 0x{frame[-1]:02x}, expected 0x5c in the {n}-byte packet at "
                f"stream offset {at}",
                offset=at,
                skipped=n,
            )
        self.packets += 1
        return Packet(frame[3], frame[4:-2])
