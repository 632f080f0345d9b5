"""A small PNG encoder (numpy + zlib): maps and figures written without an imaging library.

Writes 8-bit greyscale or RGB, with the ``pHYs`` chunk carrying the pixel density so a
150 dpi figure prints at its intended size.

>>> data = encode_png(np.zeros((2, 3), np.uint8), dpi=150)
>>> data[:8] == PNG_SIGNATURE, png_size(data), png_dpi(data)
(True, (3, 2), 150.0)
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
import numpy.typing as npt

__all__ = ["PNG_SIGNATURE", "encode_png", "png_dpi", "png_size"]

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_INCH_M = 0.0254


def _chunk(kind: bytes, body: bytes) -> bytes:
    crc = zlib.crc32(kind + body) & 0xFFFFFFFF
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)


def encode_png(image: npt.NDArray[np.uint8], *, dpi: float = 150.0, level: int = 4) -> bytes:
    """Encode ``image`` (H x W greyscale or H x W x 3 RGB, uint8, row 0 at the top).

    Rows use the PNG "up" filter (each row minus the one above, computed in one numpy
    step), which shrinks maps and figures with long vertical runs of one colour.
    """
    img = np.ascontiguousarray(image, dtype=np.uint8)
    if img.ndim == 2:
        colour_type, channels = 0, 1
    elif img.ndim == 3 and img.shape[2] == 3:
        colour_type, channels = 2, 3
    else:
        raise ValueError(f"image must be H x W or H x W x 3, got shape {img.shape}")
    h, w = img.shape[:2]
    rows = img.reshape(h, w * channels)
    up = rows.copy()
    up[1:] -= rows[:-1]  # uint8 wraps modulo 256, as the filter wants
    raw = np.empty((h, w * channels + 1), np.uint8)
    raw[:, 0] = 2  # filter type "up" (row 0 has a zero row above: the same as none)
    raw[:, 1:] = up
    ppm = round(dpi / _INCH_M)
    return b"".join(
        (
            PNG_SIGNATURE,
            _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0)),
            _chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1)),
            _chunk(b"IDAT", zlib.compress(raw.tobytes(), level)),
            _chunk(b"IEND", b""),
        )
    )


def png_size(data: bytes) -> tuple[int, int]:
    """Width and height of a PNG from its header."""
    w, h = struct.unpack(">II", data[16:24])
    return int(w), int(h)


def png_dpi(data: bytes) -> float | None:
    """The pixel density (dpi) in a PNG's ``pHYs`` chunk, or None if it has none."""
    pos = 8
    while pos + 8 <= len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        if kind == b"pHYs":
            ppx, _, unit = struct.unpack(">IIB", data[pos + 8 : pos + 17])
            return round(ppx * _INCH_M, 1) if unit == 1 else None
        if kind == b"IDAT":
            return None
        pos += 12 + length
    return None
