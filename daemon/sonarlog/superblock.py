"""Whether an HDF5 file's writer has closed it, read from the superblock alone.

HDF5 superblock versions 2 and 3 hold *file consistency flags* (byte 11): bit 0 "open
for write", bit 2 "open for SWMR write". A clean close clears them; a live writer, or one
that was killed, leaves them set. Reading 12 bytes answers without opening the file
through HDF5 (which a live SWMR writer's file would need SWMR read for).
"""

from __future__ import annotations

import os

__all__ = ["writer_closed"]


def writer_closed(path: str | os.PathLike[str]) -> bool:
    """Whether the HDF5 file's writer has closed it.

    HDF5 superblock versions 2 and 3 hold *file consistency flags* (byte 11): bit 0 "open
    for write", bit 2 "open for SWMR write". A clean close clears them; a live writer, or
    one that was killed, leaves them set. Older superblocks carry no such flags: such a
    file is taken as closed.

    Parameters
    ----------
    path : path-like
        The ``.h5`` file.

    Returns
    -------
    bool
    """
    with open(path, "rb") as fh:
        head = fh.read(12)
    if len(head) < 12 or head[:8] != b"\x89HDF\r\n\x1a\n" or head[8] not in (2, 3):
        return True
    return (head[11] & 0b101) == 0
