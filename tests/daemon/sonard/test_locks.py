"""One sonard per log and per port: a second one exits 1 naming the holder, before a byte."""

from __future__ import annotations

import errno
import fcntl
import json
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest
from procs import stop_process
from robots import WORLD, emulator_pty, start_sonard, write_plan

from sonard.log_lock import LockBusy, LogExists, LogLock, flock_holders, is_locked
from sonard.port_lock import PortLock, pid_recycled, process_start_time
from sonarlog import read_log

pytestmark = pytest.mark.timeout(120)

TIOCGEXCL = 0x80045440  # Linux: _IOR('T', 0x40, int)


def _wait_for(cond: object, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():  # type: ignore[operator]
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


def _exclusive(device: str) -> bool:
    """Whether the tty is in exclusive mode (TIOCGEXCL; EBUSY for non-root says so too)."""
    try:
        fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError as err:
        return err.errno == errno.EBUSY
    try:
        return struct.unpack("i", fcntl.ioctl(fd, TIOCGEXCL, b"\0" * 4))[0] == 1
    finally:
        os.close(fd)


def _one_line(proc: subprocess.Popen[str]) -> str:
    _, err = proc.communicate(timeout=30)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.slow
def test_second_sonard_on_the_same_log_or_port_exits_1_naming_the_first(tmp_path: Path) -> None:
    locks = tmp_path / "lock"
    locks.mkdir()
    # the first runs until stopped: the other two may take seconds to start on a loaded
    # machine, and must find it still running
    plan = write_plan(tmp_path, [{"dwell": {"seconds": 120.0}}])
    out = tmp_path / "same.h5"
    with emulator_pty(tmp_path) as (pty, _trace):
        first = start_sonard(pty, plan, out, locks)
        try:
            mine = f"{first.pid:10d}\n"
            lock_file = locks / ("LCK.." + os.path.realpath(pty)[5:].replace("/", "_"))
            _wait_for(
                lambda: is_locked(out) and lock_file.exists() and lock_file.read_text() == mine
            )
            _wait_for(lambda: _exclusive(pty))  # TIOCEXCL: set once sonard's client has the port
            url = f"nomad://other?world={WORLD}&fast=1"
            same_log = start_sonard(url, plan, out, locks)
            same_port = start_sonard(pty, plan, tmp_path / "other.h5", locks)
            log_line = _one_line(same_log)
            port_line = _one_line(same_port)
            assert same_log.returncode == 1 and same_port.returncode == 1
            assert f"PID {first.pid}" in log_line and "same.h5" in log_line
            assert f"PID {first.pid}" in port_line and pty in port_line
            assert not (tmp_path / "other.h5").exists()
            # some readings for the check below: waited for in the log itself, since how
            # many a second of wall time brings depends on the machine's load
            _wait_for(lambda: len(read_log(out).readings) > 50, timeout=60.0)
            first.send_signal(signal.SIGTERM)
            _, err = first.communicate(timeout=60)
        finally:
            stop_process(first)
    assert first.returncode == 0, err
    log = read_log(out)  # the first run's log is intact
    assert log.log_state == "closed" and log.dropped_rows == 0
    assert len(log.readings) > 50 and log.time_ordered
    assert not any(locks.iterdir())  # the lock file went with the first sonard


HOLDER = """
import fcntl, sys, termios, time, serial
s = serial.Serial(sys.argv[1], exclusive=True)
fcntl.ioctl(s.fileno(), termios.TIOCEXCL)
print("ready", flush=True)
time.sleep(60)
"""


def test_sonard_refuses_a_port_another_process_holds(tmp_path: Path) -> None:
    plan = write_plan(tmp_path, [{"dwell": {"seconds": 1.0}}])
    out = tmp_path / "run.h5"
    with emulator_pty(tmp_path) as (pty, trace):
        holder = subprocess.Popen(
            [sys.executable, "-c", HOLDER, pty], stdout=subprocess.PIPE, text=True
        )
        try:
            assert holder.stdout is not None and holder.stdout.readline().strip() == "ready"
            proc = start_sonard(pty, plan, out, tmp_path)
            line = _one_line(proc)
        finally:
            stop_process(holder)
        time.sleep(0.2)
        records = [json.loads(x) for x in trace.read_text().splitlines()] if trace.exists() else []
    assert proc.returncode == 1
    assert str(holder.pid) in line and " ERROR " in line
    assert not out.exists()
    assert not [r for r in records if r["type"] in ("command", "nak", "discard")]  # no byte sent


def test_log_lock_refuses_an_existing_log_and_names_a_live_holder(tmp_path: Path) -> None:
    path = tmp_path / "a.h5"
    with LogLock(path):
        assert is_locked(path) and flock_holders(path) == (os.getpid(),)
        with pytest.raises(LockBusy, match=f"PID {os.getpid()}"):
            LogLock(path)
    assert not is_locked(path)
    with pytest.raises(LogExists, match="refusing to overwrite"):
        LogLock(path)
    lock = LogLock(tmp_path / "b.h5")
    lock.release(remove=True)
    assert not (tmp_path / "b.h5").exists()


def test_port_lock_file_holds_the_pid_and_stale_ones_are_taken_over(tmp_path: Path) -> None:
    master, slave = os.openpty()
    try:
        device = os.ttyname(slave)
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        lock = PortLock(device, tmp_path)
        stale = tmp_path / lock.lock_name
        stale.write_text(f"{dead.pid:10d}\n")
        lock.acquire()
        assert stale.read_text() == f"{os.getpid():10d}\n"  # UUCP: ten digits and a newline
        lock.release()
        assert not stale.exists()
        stale.write_text(f"{1:10d}\n")  # PID 1 is always alive
        with pytest.raises(LockBusy, match="PID 1 "):
            PortLock(device, tmp_path).acquire()
        assert stale.read_text() == f"{1:10d}\n"  # a live owner's file is left alone
        assert lock.lock_name == "LCK.." + device.removeprefix("/dev/").replace("/", "_")
    finally:
        os.close(master)
        os.close(slave)


def test_a_recycled_pid_in_a_lock_file_is_stale_but_a_live_owner_is_not(tmp_path: Path) -> None:
    """PIDs wrap at pid_max: a live PID whose process started after the lock file was
    written is another program, unless it has the device open."""
    master, slave = os.openpty()
    newcomer = subprocess.Popen(["sleep", "60"])
    try:
        device = os.ttyname(slave)
        lock = PortLock(device, tmp_path)
        path = tmp_path / lock.lock_name
        path.write_text(f"{newcomer.pid:10d}\n")
        an_hour_ago = time.time() - 3600.0
        os.utime(path, (an_hour_ago, an_hour_ago))
        started = process_start_time(newcomer.pid)
        assert started is not None and abs(started - time.time()) < 600.0
        assert pid_recycled(newcomer.pid, path, device)
        lock.acquire()
        assert path.read_text() == f"{os.getpid():10d}\n"
        lock.release()

        # the same PID written after the process started: it may be the owner
        path.write_text(f"{newcomer.pid:10d}\n")
        assert not pid_recycled(newcomer.pid, path, device)
        with pytest.raises(LockBusy, match=f"PID {newcomer.pid} "):
            PortLock(device, tmp_path).acquire()

        # a process that has the device open is the owner whatever the clocks say
        holder = subprocess.Popen(["sleep", "60"], stdin=slave)
        try:
            path.write_text(f"{holder.pid:10d}\n")
            os.utime(path, (an_hour_ago, an_hour_ago))
            assert not pid_recycled(holder.pid, path, os.path.realpath(device))
            with pytest.raises(LockBusy, match=f"PID {holder.pid} "):
                PortLock(device, tmp_path).acquire()
        finally:
            holder.kill()
            holder.wait()
        assert path.read_text() == f"{holder.pid:10d}\n"
    finally:
        newcomer.kill()
        newcomer.wait()
        os.close(master)
        os.close(slave)
