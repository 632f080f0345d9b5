"""Open an HDF5 file that may come from a killed writer, a live writer or a cut copy.

The three cases and what we do:

* **killed or live SWMR writer**: the superblock still says "open for write", which plain
  readers refuse; SWMR-read mode ignores that flag and sees every row the writer flushed.
* **cut file** (a copy that stopped early, a full disk): HDF5 refuses a file shorter than the
  end-of-file address its superblock records. We copy it to a temporary file padded with
  zeros to that length; whatever was lost reads as zeros, which the row checks reject, so the
  caller recovers the intact prefix or gets a one-line error. HDF5 can loop forever on
  metadata that reads as zeros, so the padded copy is salvaged by
  :func:`sonarlog.recover_log` in a child process with a time limit, and we open its output.
* anything else that is not HDF5 becomes a one-line :class:`InvalidLogError`.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from sonarlog.errors import InvalidLogError
from sonarlog.state import read_superblock

if TYPE_CHECKING:  # imported as a file is opened (reading a CSV or bag log needs no HDF5)
    import h5py


def _first_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return text[0] if text else type(err).__name__


@contextlib.contextmanager
def open_log_file(path: str | os.PathLike[str]) -> Iterator[h5py.File]:
    """Open ``path`` read-only for :func:`sonarlog.read_log`, recovering what can be.

    Raises
    ------
    InvalidLogError
        If the file is missing, is not HDF5, or cannot be opened; the message names the file.
    """
    import h5py

    p = Path(path)
    if not p.is_file():
        raise InvalidLogError(f"{p}: no such file")
    try:
        is_hdf5 = h5py.is_hdf5(str(p))
    except OSError as err:
        raise InvalidLogError(f"{p}: cannot read ({_first_line(err)})") from err
    if not is_hdf5:
        raise InvalidLogError(f"{p}: not an HDF5 file")
    info = read_superblock(p)
    if info is not None and info.cut:
        with _padded_copy(p, info.stored_eof) as padded:
            salvaged = _salvage(p, padded)
            with _open_tolerant(salvaged) as handle:
                yield handle
        return
    try:
        handle = _open_tolerant(p)
    except OSError as err:
        raise InvalidLogError(f"{p}: cannot open as HDF5 ({_first_line(err)})") from err
    with handle:
        yield handle


def _open_tolerant(path: Path) -> h5py.File:
    import h5py

    try:
        return h5py.File(path, "r")
    except OSError as err:
        text = str(err)
        if "already open for write" in text or "lock" in text.lower():
            return h5py.File(path, "r", swmr=True, locking=False)
        raise


#: CPU seconds the salvage child may spend: the recovery reads a log of hours in about a
#: second, so a child still busy after this is looping on corrupt metadata. Counted in the
#: child's CPU time, not wall time, so a loaded machine that starves the child does not
#: turn a recoverable log into an unreadable one.
SALVAGE_CPU_S = 10
#: Wall seconds before a salvage child that uses no CPU (blocked) is given up: far above
#: any start-up a loaded machine delays (tens of seconds beside busy loops).
SALVAGE_TIMEOUT_S = 120.0


def _salvage(original: Path, padded: Path) -> Path:
    clean = padded.with_name("salvaged.h5")
    code = (
        "import resource, sys; "
        f"resource.setrlimit(resource.RLIMIT_CPU, ({SALVAGE_CPU_S}, {SALVAGE_CPU_S + 1})); "
        "from sonarlog import recover_log; recover_log(sys.argv[1], sys.argv[2])"
    )
    try:
        result = subprocess.run(
            [sys.executable, "-c", code, str(padded), str(clean)],
            capture_output=True,
            timeout=SALVAGE_TIMEOUT_S,
            check=False,
        )
    except subprocess.TimeoutExpired as err:
        raise InvalidLogError(f"{original}: file is cut short and its metadata is lost") from err
    if result.returncode != 0 or not clean.is_file():
        raise InvalidLogError(f"{original}: file is cut short and its metadata is lost")
    return clean


@contextlib.contextmanager
def _padded_copy(path: Path, length: int) -> Iterator[Path]:
    size = path.stat().st_size
    with tempfile.TemporaryDirectory(prefix="sonarlog-") as tmp:
        copy = Path(tmp) / path.name
        shutil.copyfile(path, copy)
        if length > size:
            with open(copy, "r+b") as fh:
                fh.truncate(length)
        yield copy
