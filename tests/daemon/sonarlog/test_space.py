"""A log whose file system fills up: the batch is refused before HDF5 sees it, and the file
closes cleanly with every row written before (the real ENOSPC run is in
tests/daemon/sonard/test_host_faults.py)."""

from __future__ import annotations

import errno
from pathlib import Path

import h5py
import numpy as np
import pytest

from sonard.crashed_logs import finalise_crashed_logs
from sonarlog import READING_DTYPE, SENSOR_DTYPE, LogWriter, read_log
from sonarlog.space import SpaceGuard, reserve_path


def _rows(n: int, t0: float) -> np.ndarray:
    r = np.zeros(n, READING_DTYPE)
    r["t"] = t0 + np.arange(n) * 0.04
    return r


def _writer(path: Path, reserve: int = 64 << 10) -> LogWriter:
    return LogWriter(path, np.zeros(1, SENSOR_DTYPE), flush_interval=0, reserve_bytes=reserve)


def test_a_batch_without_room_is_refused_and_the_log_closes_cleanly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "run.h5"
    w = _writer(path)
    assert reserve_path(path).stat().st_size == 64 << 10
    w.append(_rows(100, 0.0))
    w.event("start")
    w.flush()
    monkeypatch.setattr(SpaceGuard, "free_bytes", lambda self: 0)  # the disk is full
    w.append(_rows(50, 4.0))
    with pytest.raises(OSError) as err:
        w.flush()
    assert err.value.errno == errno.ENOSPC
    assert w.error is err.value
    w.event("error", "disk full")
    with pytest.raises(OSError):
        w.close()
    assert w.dropped_on_close == 50  # still no room after the reserve was freed
    assert not reserve_path(path).exists()
    with h5py.File(path, "r") as f:  # closed: plain HDF5 opens it
        assert f["readings"].shape == (100,)
    log = read_log(path)
    assert log.log_state == "closed" and log.dropped_rows == 0
    np.testing.assert_array_equal(log.readings["t"], _rows(100, 0.0)["t"])


def test_rows_pending_at_the_failure_are_written_when_the_reserve_makes_room(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "run.h5"
    w = _writer(path)
    w.append(_rows(10, 0.0))
    w.flush()
    free = [0]
    monkeypatch.setattr(SpaceGuard, "free_bytes", lambda self: free[0])
    w.append(_rows(5, 1.0))
    with pytest.raises(OSError):
        w.flush()
    free[0] = 10 << 20  # freeing the reserve (and more) gave room back
    with pytest.raises(OSError):  # the failure is still reported
        w.close()
    assert w.dropped_on_close == 0
    assert len(read_log(path).readings) == 15


def test_a_normal_close_gives_the_reserve_back(tmp_path: Path) -> None:
    path = tmp_path / "run.h5"
    with _writer(path) as w:
        w.append(_rows(3, 0.0))
    assert not reserve_path(path).exists()
    assert len(read_log(path).readings) == 3


def test_the_next_start_deletes_a_killed_sonards_reserve(tmp_path: Path) -> None:
    stale = reserve_path(tmp_path / "old.h5")
    stale.write_bytes(b"\0" * 1024)  # its sonard was killed; the log itself is gone too
    finalise_crashed_logs(tmp_path)
    assert not stale.exists()
