"""New readings of a sonarlog a writer is still appending to, read a slice at a time.

Re-reading a whole log on every poll costs time in proportion to its length; a live view
polls several times a second. :class:`LogTail` keeps the HDF5 file open in SWMR mode,
refreshes ``/readings`` and reads only the rows past the last it returned, checking them
as :func:`sonarlog.read_log` does (row checks where the writer sealed rows, else a finite
``t``), so a row still in flight is left for the next poll.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from sonarlog import READING_DTYPE
from sonarlog.integrity import row_checks

__all__ = ["LogTail"]

log = logging.getLogger(__name__)


class LogTail:
    """Rows appended to ``/readings`` since the last call.

    Parameters
    ----------
    path : Path
        The sonarlog (``.h5``).
    start : int
        Rows already consumed (returned by an earlier full read).
    """

    def __init__(self, path: Path, start: int = 0) -> None:
        self.path = path
        self.seen = start
        self._file: Any = None

    def _open(self) -> Any:
        import h5py

        if self._file is None:
            self._file = h5py.File(self.path, "r", swmr=True, locking=False)
        return self._file

    def new_rows(self) -> np.ndarray:
        """Intact rows past :attr:`seen` (READING_DTYPE), possibly none.

        Raises
        ------
        OSError
            The file cannot be opened or read (the caller retries later).
        """
        try:
            ds = self._open()["readings"]
            ds.refresh()
            n = int(ds.shape[0])
            if n <= self.seen:
                return np.zeros(0, dtype=READING_DTYPE)
            raw = np.asarray(ds[self.seen : n])
        except (OSError, RuntimeError, KeyError, ValueError) as err:
            self.close()  # reopen on the next poll (the writer may have closed the file)
            raise OSError(f"{self.path}: {err}") from err
        keep = self._intact(raw)
        out = np.zeros(keep, dtype=READING_DTYPE)
        for name in READING_DTYPE.names or ():
            out[name] = raw[name][:keep]
        self.seen += keep
        return out

    def _intact(self, raw: np.ndarray) -> int:
        names = raw.dtype.names or ()
        if "seq" in names and "check" in names:
            first = self.seen + 1
            ok = (raw["seq"] == np.arange(first, first + len(raw), dtype=np.uint32)) & (
                raw["check"] == row_checks(raw)
            )
        else:
            ok = np.isfinite(raw["t"])
        bad = np.flatnonzero(~ok)
        return int(bad[0]) if len(bad) else len(raw)

    def close(self) -> None:
        """Close the file (the next :meth:`new_rows` reopens it)."""
        if self._file is not None:
            try:
                self._file.close()
            except Exception as err:  # closing a file its writer truncated
                log.debug("close %s: %s", self.path, err)
            self._file = None
