"""Row integrity for crash-safe appends.

A writer killed mid-append can leave rows the disk never fully received: the dataset's
extent reached the file but the chunk holding the rows did not, or only part of it did.
Every stored reading therefore carries ``seq`` (its 1-based row number) and ``check`` (a
position-weighted sum of the row's other bytes, modulo 2**32). A row whose ``seq`` is not its
row number, or whose ``check`` does not match, is torn; the reader keeps the prefix before
the first torn row. Both are computed for a whole batch with one matrix product.
"""

from __future__ import annotations

import numpy as np

from sonarlog.schema import READING_DTYPE, STORED_READING_DTYPE

_PAYLOAD_BYTES = READING_DTYPE.itemsize + 4  # the contract fields plus seq
# Odd multipliers from Knuth's multiplicative hash: a zeroed or shifted byte changes the sum.
_WEIGHTS = ((np.arange(1, _PAYLOAD_BYTES + 1, dtype=np.uint64) * 2654435761) % 2**32) | 1


def row_checks(stored: np.ndarray) -> np.ndarray:
    """Return the ``check`` value of each row of a :data:`STORED_READING_DTYPE` array."""
    raw = np.ascontiguousarray(stored).view(np.uint8).reshape(len(stored), -1)
    payload = raw[:, :_PAYLOAD_BYTES].astype(np.uint64)
    # Each product is < 2**40 and there are < 2**8 of them, so the uint64 sum cannot wrap.
    return ((payload @ _WEIGHTS) % 2**32).astype(np.uint32)


def seal(readings: np.ndarray, first_seq: int) -> np.ndarray:
    """Return ``readings`` as stored rows numbered from ``first_seq`` with their checks."""
    stored = np.zeros(len(readings), dtype=STORED_READING_DTYPE)
    for name in READING_DTYPE.names or ():
        stored[name] = readings[name]
    stored["seq"] = np.arange(first_seq, first_seq + len(readings), dtype=np.uint32)
    stored["check"] = row_checks(stored)
    return stored


def intact_prefix(stored: np.ndarray) -> int:
    """Return how many leading rows of a stored readings array are intact."""
    if len(stored) == 0:
        return 0
    ok = (stored["seq"] == np.arange(1, len(stored) + 1, dtype=np.uint32)) & (
        stored["check"] == row_checks(stored)
    )
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if len(bad) else len(stored)
