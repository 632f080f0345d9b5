"""A resynchronising decoder for a byte stream of Nomad 200 packets.

Feed it whatever the port returned; it yields complete :class:`~nomad200.codec.Packet`
objects and, for damage, :class:`~nomad200.errors.FrameError` instances (not raised) that
say what was wrong, where, and how many bytes were discarded. After damage it looks for the
next start byte and carries on, so one garbled packet costs one packet.

Examples
--------
>>> from nomad200.codec import Cmd, encode_frame
>>> dec = StreamDecoder()
>>> good = encode_frame(Cmd.GS, b"")
>>> bad = bytearray(good); bad[-2] ^= 0xFF
>>> [type(e).__name__ for e in dec.feed(b"zz" + bytes(bad) + good)]
['GarbageError', 'ChecksumError', 'GarbageError', 'Packet']
>>> dec.skipped_bytes
8
"""

from __future__ import annotations

from collections.abc import Collection

from nomad200.codec import END, MAX_LENGTH, START, Packet
from nomad200.errors import (
    ChecksumError,
    EndByteError,
    FrameError,
    GarbageError,
    LengthError,
    TruncatedPacketError,
)

__all__ = ["StreamDecoder"]

_START = bytes((START,))


class StreamDecoder:
    """Incremental packet decoder with resynchronisation.

    Parameters
    ----------
    max_length : int
        Largest acceptable ``len`` field.
    accept_lengths : collection of int, optional
        If given, only these ``len`` values are accepted (a client that knows which reply
        it waits for passes the expected length and 2 for a NAK); anything else is treated
        as a false start byte. Change it any time with :attr:`accept_lengths`.

    Attributes
    ----------
    skipped_bytes : int
        Bytes discarded so far (garbage, false starts, truncated tails).
    errors : int
        Framing errors reported so far.
    packets : int
        Good packets decoded so far.
    """

    def __init__(
        self, *, max_length: int = MAX_LENGTH, accept_lengths: Collection[int] | None = None
    ) -> None:
        self.max_length = max_length
        self.accept_lengths = accept_lengths
        self._buf = bytearray()
        self._offset = 0
        self.skipped_bytes = 0
        self.errors = 0
        self.packets = 0

    @property
    def pending(self) -> int:
        """Bytes held that do not form a complete packet yet."""
        return len(self._buf)

    def needed(self) -> int:
        """How many more bytes could complete the packet being assembled (at least 1)."""
        buf = self._buf
        n = len(buf)
        if n < 3:
            return 3 - n
        length = buf[1] | (buf[2] << 8)
        return max(1, length + 4 - n)

    def feed(self, data: bytes | bytearray | memoryview) -> list[Packet | FrameError]:
        """Add bytes and return the packets and framing errors they complete, in order."""
        buf = self._buf
        buf += data
        out: list[Packet | FrameError] = []
        pos = 0
        size = len(buf)
        accept = self.accept_lengths
        while pos < size:
            if buf[pos] != START:
                j = buf.find(_START, pos)
                end = size if j < 0 else j
                out.append(self._err(GarbageError, "byte(s) before a start byte", pos, end - pos))
                pos = end
                continue
            if size - pos < 3:
                break
            length = buf[pos + 1] | (buf[pos + 2] << 8)
            if length < 2 or length > self.max_length or (accept and length not in accept):
                out.append(self._err(LengthError, f"implausible length field {length}", pos, 1))
                pos += 1
                continue
            stop = pos + length + 4
            if stop > size:
                break
            want = sum(buf[pos : stop - 2]) & 0xFF
            got = buf[stop - 2]
            if got != want:
                out.append(
                    self._err(ChecksumError, f"checksum 0x{got:02x}, expected 0x{want:02x}", pos, 1)
                )
                pos += 1
                continue
            if buf[stop - 1] != END:
                out.append(
                    self._err(
                        EndByteError, f"end byte 0x{buf[stop - 1]:02x}, expected 0x5c", pos, 1
                    )
                )
                pos += 1
                continue
            out.append(Packet(buf[pos + 3], bytes(buf[pos + 4 : stop - 2])))
            self.packets += 1
            pos = stop
        if pos:
            del buf[:pos]
            self._offset += pos
        return out

    def flush(self) -> TruncatedPacketError | None:
        """Declare the stream ended (or timed out): a partial packet becomes an error."""
        n = len(self._buf)
        if not n:
            return None
        err = self._err(TruncatedPacketError, f"stream stopped after {n} byte(s) of a packet", 0, n)
        self._offset += n
        self._buf.clear()
        assert isinstance(err, TruncatedPacketError)
        return err

    def reset(self) -> int:
        """Drop buffered bytes silently (e.g. after flushing the port); return how many."""
        n = len(self._buf)
        self._offset += n
        self.skipped_bytes += n
        self._buf.clear()
        return n

    def _err(self, cls: type[FrameError], what: str, pos: int, skipped: int) -> FrameError:
        at = self._offset + pos
        self.skipped_bytes += skipped
        self.errors += 1
        return cls(
            f"{what} at stream offset {at} ({skipped} byte(s) skipped)", offset=at, skipped=skipped
        )
