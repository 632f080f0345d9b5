"""SIGKILLed sonards: the next start finalises their logs, which plain h5py then opens."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from procs import stop_process
from robots import emulator_pty, start_sonard, write_plan

from sonard.crashed_logs import finalise_crashed_logs
from sonard.log_lock import LogLock
from sonarlog import read_log, read_superblock

pytestmark = pytest.mark.timeout(180)

KILL_TRIALS = 4

WRITER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from sonarlog import LogWriter, READING_DTYPE, SENSOR_DTYPE
    sensors = np.zeros(1, SENSOR_DTYPE)
    attrs = {"acquired_by": sys.argv[2]}
    with LogWriter(sys.argv[1], sensors, attrs=attrs, flush_interval=0.05) as w:
        for i in range(int(sys.argv[3])):
            rows = np.zeros(10, READING_DTYPE)
            rows["t"] = time.time()
            w.append(rows)
        w.flush()
        print("ready", flush=True)
        time.sleep(60)
    """
)


def _crashed_log(path: Path, by: str = "sonard", batches: int = 5) -> None:
    with subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path), by, str(batches)], stdout=subprocess.PIPE
    ) as proc:
        assert proc.stdout is not None and proc.stdout.readline().strip() == b"ready"
        proc.send_signal(signal.SIGKILL)
        proc.wait()


def test_start_up_scan_finalises_crashed_sonard_logs_only(tmp_path: Path) -> None:
    _crashed_log(tmp_path / "crashed.h5")
    _crashed_log(tmp_path / "empty.h5", batches=0)
    _crashed_log(tmp_path / "foreign.h5", by="someone else")
    _crashed_log(tmp_path / "live.h5")
    (tmp_path / "stub.h5").write_bytes(b"")  # killed between creating and writing the file
    with pytest.raises(OSError):
        h5py.File(tmp_path / "crashed.h5", "r").close()
    live = os.open(tmp_path / "live.h5", os.O_RDONLY)
    import fcntl

    fcntl.flock(live, fcntl.LOCK_EX)  # as a running sonard holds its log
    try:
        done = {d.path.name: d for d in finalise_crashed_logs(tmp_path, skip=tmp_path / "x.h5")}
    finally:
        os.close(live)
    assert done["crashed.h5"].action == "finalised" and done["crashed.h5"].readings == 50
    assert done["empty.h5"].action == "removed" and not (tmp_path / "empty.h5").exists()
    assert done["stub.h5"].action == "removed" and not (tmp_path / "stub.h5").exists()
    assert "foreign.h5" not in done and "live.h5" not in done
    with h5py.File(tmp_path / "crashed.h5", "r") as f:  # plain HDF5 opens it now
        assert f["readings"].shape == (50,)
    log = read_log(tmp_path / "crashed.h5")
    assert log.log_state == "crashed" and log.intact_rows == 50 and log.dropped_rows == 0
    warning = log.integrity_warning()
    assert warning is not None and "50 intact readings" in warning and "finalised" in warning
    for name in ("foreign.h5", "live.h5"):
        info = read_superblock(tmp_path / name)
        assert info is not None and info.open_for_write


def test_sigkilled_sonards_leave_logs_plain_h5py_opens_after_the_next_start(
    tmp_path: Path,
) -> None:
    locks = tmp_path / "lock"
    locks.mkdir()
    plan = write_plan(tmp_path, [{"dwell": {"seconds": 60.0}}], pose_attachments=True)
    rng = np.random.default_rng(7)
    killed: list[tuple[Path, float]] = []
    with emulator_pty(tmp_path) as (pty, _trace):
        for i in range(KILL_TRIALS + 1):
            out = tmp_path / f"run-{i}.h5"
            proc = start_sonard(pty, plan, out, locks)
            try:
                if i == KILL_TRIALS:  # this start finalises the last killed log
                    _wait_until_closed(killed[-1][0])
                    _wait_until_owner(locks, proc.pid)
                    proc.send_signal(signal.SIGTERM)
                    _, err = proc.communicate(timeout=30)
                    assert proc.returncode == 0, err
                    break
                time.sleep(float(rng.uniform(0.8, 3.0)))
                killed.append((out, time.time()))
                proc.kill()
                proc.wait(10)
            finally:
                stop_process(proc)
    assert not any(locks.iterdir())  # stale lock files were taken over and removed
    for path, kill_t in killed:
        if not path.exists():
            continue  # killed before its first reading: the next start removed it
        with h5py.File(path, "r") as f:
            n = f["readings"].shape[0]
        log = read_log(path)
        assert log.log_state == "crashed" and n == log.intact_rows
        if n:
            assert kill_t - float(log.readings["t"].max()) <= 1.0
            assert log.time_ordered


def _wait_until_owner(locks: Path, pid: int, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if any(p.read_text().strip() == str(pid) for p in locks.glob("LCK..*")):
            return
        time.sleep(0.05)
    raise AssertionError(f"sonard {pid} never took the port lock")


def _wait_until_closed(path: Path, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not path.exists():
            return
        info = read_superblock(path)
        if info is not None and not info.open_for_write:
            return
        time.sleep(0.05)
    raise AssertionError(f"{path} was not finalised")


def test_a_run_that_fails_before_its_first_reading_leaves_no_log(tmp_path: Path) -> None:
    lock = LogLock(tmp_path / "x.h5")
    lock.release(remove=True)
    assert not (tmp_path / "x.h5").exists()
