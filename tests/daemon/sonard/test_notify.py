"""sd_notify against real unix datagram sockets (path and abstract namespace)."""

from __future__ import annotations

import os
import socket
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from sonard.notify import Notifier


@pytest.fixture
def path_socket(tmp_path: Path) -> Iterator[tuple[socket.socket, str]]:
    addr = str(tmp_path / "notify.sock")
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    s.bind(addr)
    s.settimeout(2.0)
    yield s, addr
    s.close()


def _recv(s: socket.socket) -> str:
    return s.recv(4096).decode()


def test_ready_watchdog_stopping_on_path_socket(path_socket: tuple[socket.socket, str]) -> None:
    s, addr = path_socket
    t = [100.0]
    n = Notifier(env={"NOTIFY_SOCKET": addr, "WATCHDOG_USEC": "4000000"}, clock=lambda: t[0])
    assert n.enabled and n.watchdog_period == 2.0
    assert not n.watchdog()  # not before READY
    assert n.ready("running plan x")
    assert _recv(s) == "READY=1\nSTATUS=running plan x"
    assert n.watchdog()
    assert _recv(s) == "WATCHDOG=1"
    t[0] += 1.0
    assert not n.watchdog()  # rate-limited to half of WatchdogSec
    t[0] += 1.5
    assert n.watchdog()
    assert _recv(s) == "WATCHDOG=1"
    assert n.stopping("plan completed")
    assert _recv(s) == "STOPPING=1\nSTATUS=plan completed"
    n.close()


def test_abstract_namespace_socket() -> None:
    name = f"sonard-test-{uuid.uuid4().hex}"
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    s.bind(b"\0" + name.encode())
    s.settimeout(2.0)
    try:
        n = Notifier(env={"NOTIFY_SOCKET": "@" + name})
        assert n.send("READY=1")
        assert _recv(s) == "READY=1"
        n.close()
    finally:
        s.close()


def test_no_socket_is_a_no_op() -> None:
    n = Notifier(env={})
    assert not n.enabled
    assert not n.ready() and not n.watchdog(force=True) and not n.stopping()


def test_watchdog_for_another_pid_is_ignored(path_socket: tuple[socket.socket, str]) -> None:
    _, addr = path_socket
    env = {"NOTIFY_SOCKET": addr, "WATCHDOG_USEC": "1000000", "WATCHDOG_PID": str(os.getpid() + 1)}
    assert Notifier(env=env).watchdog_period == 0


def test_vanished_socket_is_logged_not_raised(tmp_path: Path) -> None:
    n = Notifier(env={"NOTIFY_SOCKET": str(tmp_path / "gone.sock")})
    assert not n.ready()
    n.close()


def test_no_watchdog_ping_after_stopping(tmp_path: Path) -> None:
    addr = str(tmp_path / "notify.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(addr)
    server.settimeout(1.0)
    n = Notifier(env={"NOTIFY_SOCKET": addr, "WATCHDOG_USEC": "1000"})
    try:
        assert n.ready()
        assert n.stopping("done")
        assert n.watchdog() is False and n.watchdog(force=True) is False
        msgs = [server.recv(4096).decode() for _ in range(2)]
        assert msgs[-1].startswith("STOPPING=1")
    finally:
        n.close()
        server.close()
