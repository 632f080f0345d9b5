"""The writer thread: order kept, producers never block, errors surface on close."""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from sonard.ring import ring_sensors
from sonard.writer_thread import LogSink
from sonarlog import POSE_DTYPE, READING_DTYPE, LogWriter, read_log


class SlowWriter:
    def __init__(self) -> None:
        self.gate = threading.Event()
        self.rows: list[np.ndarray] = []
        self.events: list[str] = []
        self.closed = False

    def append(self, readings: np.ndarray) -> None:
        self.gate.wait(5)
        self.rows.append(readings)

    def append_poses(self, poses: np.ndarray) -> None:
        pass

    def event(self, kind: str, detail: str = "", t: float | None = None) -> None:
        self.events.append(kind)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        self.closed = True


def _readings(n: int, start: int = 0) -> np.ndarray:
    r = np.zeros(n, READING_DTYPE)
    r["t"] = np.arange(start, start + n, dtype=float)
    r["tx"] = r["rx"] = 3
    r["tof"] = 0.01
    return r


def test_producer_does_not_wait_for_a_blocked_disk() -> None:
    w = SlowWriter()
    sink = LogSink(w)
    for i in range(100):  # the writer is blocked: these must all return at once
        sink.readings(_readings(2, 2 * i))
    sink.event("start")
    assert sink.n_readings == 200
    w.gate.set()
    sink.close()
    got = np.concatenate(w.rows)
    np.testing.assert_array_equal(got["t"], np.arange(200.0))
    assert w.events == ["start"] and w.closed


def test_writes_a_valid_log(tmp_path: Path) -> None:
    path = tmp_path / "x.h5"
    sink = LogSink(LogWriter(path, ring_sensors(), robot="nomad200"))
    sink.event("start", "test")
    sink.readings(_readings(5))
    p = np.zeros(2, POSE_DTYPE)
    p["t"] = [1.0, 2.0]
    sink.poses(p)
    sink.readings(np.zeros(0, READING_DTYPE))
    sink.close()
    log = read_log(path)
    assert len(log.readings) == 5
    assert len(log.sensors) == 16
    assert log.poses is not None and len(log.poses) == 2


class FailingWriter(SlowWriter):
    def append(self, readings: np.ndarray) -> None:
        raise OSError(28, "No space left on device")


def test_writer_error_is_raised_on_close() -> None:
    sink = LogSink(FailingWriter())
    sink.readings(_readings(1))
    sink.readings(_readings(1))
    with pytest.raises(OSError, match="No space"):
        sink.close()


class SteadyWriter(SlowWriter):
    """A writer on a loaded machine: every append takes a while, but each one completes."""

    def __init__(self, per_append_s: float) -> None:
        super().__init__()
        self.per_append_s = per_append_s

    def append(self, readings: np.ndarray) -> None:
        time.sleep(self.per_append_s)
        self.rows.append(readings)


def test_close_waits_for_a_slow_drain_that_makes_progress() -> None:
    # 100 appends of 20 ms: a drain of at least 2 s, four times the stuck bound given, is
    # waited for because every append completes well inside it
    w = SteadyWriter(0.02)
    sink = LogSink(w)
    for i in range(100):
        sink.readings(_readings(2, 2 * i))
    sink.event("stop")
    sink.close(stuck_s=0.5)
    got = np.concatenate(w.rows)
    np.testing.assert_array_equal(got["t"], np.arange(200.0))
    assert sink.n_written == 201 and w.events == ["stop"] and w.closed


def test_close_gives_up_on_a_stuck_writer(caplog: pytest.LogCaptureFixture) -> None:
    w = SlowWriter()  # its append waits for the gate, which opens only after close
    sink = LogSink(w)
    sink.readings(_readings(2))
    sink.readings(_readings(2, 2))
    with caplog.at_level(logging.ERROR, logger="sonard.writer_thread"):
        sink.close(stuck_s=0.2)
    assert w.closed and sink.n_written == 0
    w.gate.set()
    assert [r.getMessage() for r in caplog.records] == [
        "log writer stuck: nothing written for 0.2 s, queued records lost"
    ]
