"""Serial link budget: bytes per state poll and the poll period a baud rate allows.

A Nomad packet is framed as ``0x01 | len_lo | len_hi | type | payload | checksum | 0x5C``
(5 bytes of framing around type + payload). A GS request has no payload (6 bytes on the
wire). Its state reply, for a mask of ``n`` sonars plus x, y, steer and turret, holds the
type byte, one byte per sonar, 36 bytes per sonar pose attachment, 4 x 2 pose bytes, the
motor status byte, a 4-byte clock and two voltage bytes. Each byte is 10 bits on an 8N1
line.
"""

from __future__ import annotations

__all__ = ["ATTACHMENT_BYTES", "poll_bytes", "poll_seconds", "reply_bytes"]

FRAME_BYTES = 5
ATTACHMENT_BYTES = 36
BITS_PER_BYTE = 10
GS_REQUEST_BYTES = FRAME_BYTES + 1


def reply_bytes(n_sonars: int, attachments: bool, *, pose: bool = True) -> int:
    """Bytes on the wire for one state reply.

    Parameters
    ----------
    n_sonars : int
        Masked sonars.
    attachments : bool
        Whether each masked sonar carries a 36-byte pose attachment.
    pose : bool
        Whether x, y, steer and turret are masked.

    Returns
    -------
    int
        Framing included.

    Examples
    --------
    >>> reply_bytes(5, False)
    26
    """
    body = 1 + n_sonars * (1 + (ATTACHMENT_BYTES if attachments else 0))
    body += 8 if pose else 0
    body += 1 + 4 + 2  # motor status, clock, voltages
    return FRAME_BYTES + body


def poll_bytes(n_sonars: int, attachments: bool) -> int:
    """Bytes of a GS request plus its reply."""
    return GS_REQUEST_BYTES + reply_bytes(n_sonars, attachments)


def poll_seconds(n_sonars: int, attachments: bool, baud: int) -> float:
    """Time the line needs for one GS poll at ``baud`` (s), not counting robot latency.

    Examples
    --------
    >>> round(poll_seconds(5, True, 38400), 4)
    0.0552
    """
    return poll_bytes(n_sonars, attachments) * BITS_PER_BYTE / baud
