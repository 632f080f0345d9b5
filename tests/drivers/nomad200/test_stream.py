"""The resynchronising stream decoder: precise errors, then the next good packet."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nomad200.codec import Cmd, Packet, encode_command, encode_frame
from nomad200.errors import (
    ChecksumError,
    EndByteError,
    FrameError,
    GarbageError,
    LengthError,
    TruncatedPacketError,
)
from nomad200.stream import StreamDecoder

GS = encode_command(Cmd.GS)
PR = encode_command(Cmd.PR, 100, -450, 0)


def kinds(events: list[Packet | FrameError]) -> list[str]:
    return [type(e).__name__ for e in events]


def test_garbage_before_start_byte() -> None:
    dec = StreamDecoder()
    ev = dec.feed(b"\xff\xfe\x00" + GS)
    assert kinds(ev) == ["GarbageError", "Packet"]
    assert isinstance(ev[0], GarbageError)
    assert ev[0].offset == 0 and ev[0].skipped == 3
    assert ev[1] == Packet(Cmd.GS, b"")
    assert dec.skipped_bytes == 3


def test_wrong_checksum_then_resync() -> None:
    bad = bytearray(PR)
    bad[-2] ^= 0x01
    dec = StreamDecoder()
    ev = dec.feed(bytes(bad) + GS)
    assert isinstance(ev[0], ChecksumError)
    assert ev[0].offset == 0 and "expected 0xb3" in str(ev[0])
    assert ev[-1] == Packet(Cmd.GS, b"")
    assert dec.skipped_bytes == len(PR)
    assert all(isinstance(e, FrameError) for e in ev[:-1])


def test_wrong_end_byte_then_resync() -> None:
    bad = bytearray(GS)
    bad[-1] = 0x00
    dec = StreamDecoder()
    ev = dec.feed(bytes(bad) + PR)
    assert isinstance(ev[0], EndByteError) and "end byte 0x00" in str(ev[0])
    assert ev[-1] == Packet(Cmd.PR, PR[4:-2])
    assert dec.skipped_bytes == len(GS)


def test_truncated_packet_is_reported_on_flush() -> None:
    dec = StreamDecoder()
    assert dec.feed(PR[:7]) == []
    assert dec.needed() == len(PR) - 7
    err = dec.flush()
    assert isinstance(err, TruncatedPacketError)
    assert err.skipped == 7 and err.offset == 0
    assert dec.feed(GS) == [Packet(Cmd.GS, b"")]


def test_truncated_packet_followed_by_good_one() -> None:
    dec = StreamDecoder()
    ev = dec.feed(PR[:6] + GS + GS)
    assert ev[-2:] == [Packet(Cmd.GS, b""), Packet(Cmd.GS, b"")]
    assert isinstance(ev[0], ChecksumError | EndByteError)
    assert dec.skipped_bytes == 6


def test_length_filter_rejects_false_starts() -> None:
    dec = StreamDecoder(accept_lengths=(2,))
    ev = dec.feed(b"\x01\xff\x07" + GS)
    assert isinstance(ev[0], LengthError)
    assert ev[-1] == Packet(Cmd.GS, b"")


def test_byte_at_a_time() -> None:
    dec = StreamDecoder()
    out = []
    for b in PR + GS:
        out += dec.feed(bytes([b]))
    assert out == [Packet(Cmd.PR, PR[4:-2]), Packet(Cmd.GS, b"")]


frames = st.lists(
    st.tuples(st.integers(0, 255), st.binary(max_size=40)).map(lambda t: encode_frame(*t)),
    min_size=1,
    max_size=8,
)
noise = st.binary(max_size=12).map(lambda b: b.replace(b"\x01", b"\x02"))


@settings(max_examples=100, deadline=None)
@given(frames, st.lists(noise, min_size=9, max_size=9), st.integers(1, 64))
def test_packets_survive_noise_between_them(fs: list[bytes], gaps: list[bytes], chunk: int) -> None:
    """Noise without start bytes between packets costs exactly the noise."""
    stream = b"".join(g + f for g, f in zip(gaps, fs, strict=False))
    dec = StreamDecoder()
    out: list[Packet | FrameError] = []
    for i in range(0, len(stream), chunk):
        out += dec.feed(stream[i : i + chunk])
    got = [e for e in out if isinstance(e, Packet)]
    assert got == [Packet(f[3], f[4:-2]) for f in fs]
    assert dec.skipped_bytes == sum(len(g) for g in gaps[: len(fs)])
    assert dec.pending == 0


@settings(max_examples=100, deadline=None, derandomize=True)  # a 1/65536 false packet is possible
@given(frames, st.integers(0, 10_000))
def test_one_damaged_byte_costs_at_most_its_packet(fs: list[bytes], where: int) -> None:
    stream = bytearray(b"".join(fs))
    i = where % len(stream)
    stream[i] ^= 0xA5
    dec = StreamDecoder(accept_lengths={len(f) - 4 for f in fs})
    out = dec.feed(bytes(stream))
    dec.flush()
    got = [e for e in out if isinstance(e, Packet)]
    # which frame held the damaged byte
    ends = [sum(len(f) for f in fs[: k + 1]) for k in range(len(fs))]
    k = next(j for j, e in enumerate(ends) if i < e)
    want = [Packet(f[3], f[4:-2]) for j, f in enumerate(fs) if j != k]
    # every undamaged packet is recovered, in order (a damaged length may hide nothing else)
    it = iter(got)
    assert all(any(w == g for g in it) for w in want)


@pytest.mark.parametrize("n", [0, 1, 2])
def test_needed_counts_header_first(n: int) -> None:
    dec = StreamDecoder()
    dec.feed(GS[:n])
    assert dec.needed() == 3 - n
