"""A writer killed at any moment, and files cut at any byte, lose nothing they should keep."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from logbuilders import random_readings, ring_sensors

from sonarlog import InvalidLogError, LogWriter, read_log
from sonarlog.integrity import intact_prefix, seal

WRITER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    sys.path.insert(0, sys.argv[2])
    from logbuilders import ring_sensors
    from sonarlog import LogWriter, READING_DTYPE

    if len(sys.argv) > 3:  # a slow disk: every fsync takes this long
        import os, sonarlog.writer
        fsync, pause = os.fsync, float(sys.argv[3])
        sonarlog.writer.os.fsync = lambda fd: (time.sleep(pause), fsync(fd))[1]
    n = 0
    with LogWriter(sys.argv[1], ring_sensors(), robot="kill-test", flush_interval=0.5) as w:
        print("ready", time.time(), flush=True)
        while True:
            batch = np.zeros(8, READING_DTYPE)
            batch["t"] = t = time.time()
            batch["tof"] = np.arange(n, n + 8)
            w.append(batch)
            print("appended", repr(t), flush=True)
            n += 8
            time.sleep(0.004)
    """
)

KILL_TRIALS = 24


def _kill_trial(
    tmp: Path, delay: float, slow_fsync: float | None = None
) -> tuple[Path, float, list[float]]:
    """Kill a writer ``delay`` s after it is ready; return the log, the ready time and the
    times of the batches the writer appended (its own clock, printed after each append:
    what it could have kept, whatever the machine's load let it do)."""
    path = tmp / f"killed-{delay:.3f}.h5"
    support = str(Path(__file__).parents[2] / "support")
    with subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path), support]
        + ([] if slow_fsync is None else [str(slow_fsync)]),
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    ) as proc:
        try:
            assert proc.stdout is not None
            word, ready_at = proc.stdout.readline().split()
            assert word == b"ready"
            time.sleep(delay)  # 2.5 s of lines (~12 kB) fit in the pipe: the writer never blocks
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
            lines = [ln.split() for ln in proc.stdout.read().splitlines()]
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    appended = [float(ln[1]) for ln in lines if len(ln) == 2 and ln[0] == b"appended"]
    return path, float(ready_at), appended


def _lost(path: Path, ready_at: float, appended: list[float]) -> float:
    """Seconds of appended readings the killed log does not hold (see the caller)."""
    log = read_log(path)
    last = log.readings["t"][-1] if len(log.readings) else -np.inf
    return max(appended, default=ready_at) - max(last, ready_at)


@pytest.mark.slow
def test_sigkill_at_random_moments_loses_nothing_older_than_one_second(tmp_path: Path) -> None:
    delays = np.random.default_rng(20240601).uniform(0.05, 2.5, KILL_TRIALS)
    with ThreadPoolExecutor(max_workers=4) as pool:
        trials = list(pool.map(lambda d: _kill_trial(tmp_path, float(d)), delays))
    for path, ready_at, appended in trials:
        log = read_log(path)
        n = len(log.readings)
        assert log.log_state == "crashed" and not log.live
        warning = log.integrity_warning()
        assert warning is not None and f"{n} intact readings" in warning
        # The intact prefix is exactly the rows appended, in order, with nothing in between.
        np.testing.assert_array_equal(log.readings["tof"], np.arange(n))
        assert n == 0 or np.all(np.diff(log.readings["t"]) >= 0)
        # What the writer had appended after the last surviving reading is what the kill
        # lost (a writer the machine starved appended nothing meanwhile: nothing to lose).
        lost_window = _lost(path, ready_at, appended)
        assert lost_window <= 1.0, f"{path.name}: lost {lost_window:.2f} s of readings"


def test_a_slow_disk_holds_up_neither_the_pushes_nor_the_appends(tmp_path: Path) -> None:
    # every fsync takes 1.5 s: were the pushes to wait for it, or the appends for the
    # lock, a kill would lose up to 2 s and the writer would stall for 1.5 s at a time
    delays = (1.6, 2.2, 2.7)
    with ThreadPoolExecutor(max_workers=3) as pool:
        trials = list(pool.map(lambda d: _kill_trial(tmp_path, d, slow_fsync=1.5), delays))
    for path, ready_at, appended in trials:
        lost_window = _lost(path, ready_at, appended)
        assert lost_window <= 1.0, f"{path.name}: lost {lost_window:.2f} s of readings"
        gaps = np.diff([ready_at, *appended])
        assert gaps.max() < 1.0, f"{path.name}: an append waited {gaps.max():.2f} s"


def _complete_log(path: Path) -> np.ndarray:
    readings = random_readings(np.random.default_rng(11), 30_000)
    with LogWriter(path, ring_sensors(), robot="cut-test", flush_interval=0) as w:
        for part in np.array_split(readings, 15):
            w.append(part)
            w.flush()
    return readings


# twelve salvage processes in turn: a second each on a machine with a core to spare, tens
# of seconds each beside two busy loops and other tests
@pytest.mark.slow
@pytest.mark.timeout(900)
def test_files_cut_at_random_offsets_give_a_prefix_or_a_one_line_error(tmp_path: Path) -> None:
    source = tmp_path / "whole.h5"
    readings = _complete_log(source)
    data = source.read_bytes()
    offsets = np.random.default_rng(12).integers(0, len(data), 12)  # each read costs a process
    recovered = 0
    for off in sorted(int(o) for o in offsets):
        cut = tmp_path / f"cut-{off}.h5"
        cut.write_bytes(data[:off])
        try:
            log = read_log(cut)
        except InvalidLogError as err:
            message = str(err)
            assert str(cut) in message
            assert "\n" not in message
            continue
        recovered += 1
        n = len(log.readings)
        np.testing.assert_array_equal(log.readings, readings[:n])
        # never silent: the state, the counts and the warning say what was lost
        assert log.log_state == "cut" and log.intact_rows == n
        assert log.dropped_rows == len(readings) - n
        warning = log.integrity_warning()
        assert warning is not None and "\n" not in warning
        assert f"{n} intact readings, {len(readings) - n} torn rows dropped" in warning
        assert warning.endswith(f"sonarproc recover {cut}")
    assert recovered > 0  # the padding recovery works for at least some cuts


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(1, 40),
    row=st.integers(0, 39),
    byte=st.integers(0, 58),
    delta=st.integers(1, 255),
)
def test_any_changed_byte_marks_its_row_torn(n: int, row: int, byte: int, delta: int) -> None:
    rows = seal(random_readings(np.random.default_rng(n), n), 1)
    assert intact_prefix(rows) == n
    row %= n
    raw = rows.view(np.uint8).reshape(n, -1)
    raw[row, byte] = (int(raw[row, byte]) + delta) % 256
    assert intact_prefix(rows) == row


def test_zeroed_tail_rows_are_dropped() -> None:
    rows = seal(random_readings(np.random.default_rng(1), 50), 1)
    rows[30:] = np.zeros(20, dtype=rows.dtype)
    assert intact_prefix(rows) == 30


@pytest.mark.parametrize("interval", [0.05, 0.5])
def test_background_flush_makes_readings_visible_to_a_live_reader(
    tmp_path: Path, interval: float
) -> None:
    path = tmp_path / "live.h5"
    readings = random_readings(np.random.default_rng(3), 100)
    with LogWriter(path, ring_sensors(), flush_interval=interval) as w:
        w.append(readings)
        # the push thread flushes every `interval`; a loaded machine can keep it off the
        # CPU for seconds, so wait on the condition with a generous bound (it ends at once
        # when the readings show)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if len(read_log(path).readings) == 100:
                break
            time.sleep(0.02)
        np.testing.assert_array_equal(read_log(path).readings, readings)


def test_a_closed_log_reads_as_closed_without_warning(tmp_path: Path) -> None:
    path = tmp_path / "closed.h5"
    readings = random_readings(np.random.default_rng(5), 100)
    readings["t"] = np.sort(readings["t"])
    with LogWriter(path, ring_sensors(), flush_interval=0) as w:
        w.append(readings)
    log = read_log(path)
    assert (log.log_state, log.intact_rows, log.dropped_rows) == ("closed", 100, 0)
    assert log.integrity_warning() is None and log.time_ordered


def test_reader_counts_backward_steps_and_still_reads(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "unordered.h5"
    readings = random_readings(np.random.default_rng(6), 50)
    readings["t"] = np.arange(50.0)
    readings["t"][[10, 30]] = [5.0, 1.0]  # two steps back (and two forward again)
    with LogWriter(path, ring_sensors(), flush_interval=0) as w:
        w.append(readings)
    log = read_log(path)
    assert len(log.readings) == 50 and not log.time_ordered and log.backward_steps == 2
    assert "not in time order" in caplog.text


def test_a_live_sonard_log_reads_as_live(tmp_path: Path) -> None:
    import fcntl

    path = tmp_path / "live.h5"
    fd = os.open(path, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)  # what sonard holds while it writes
    try:
        with LogWriter(path, ring_sensors(), flush_interval=0) as w:
            w.append(random_readings(np.random.default_rng(8), 10))
            w.flush()
            log = read_log(path)
            assert log.live and log.log_state == "crashed"
            assert "still being written" in (log.integrity_warning() or "")
    finally:
        os.close(fd)
