"""``sonard`` through ``main(argv)`` against the in-process emulator (``nomad://``)."""

from __future__ import annotations

import contextlib
import datetime as dt
import socket
import threading
from pathlib import Path

import numpy as np
import pytest
import yaml

from sonard.cli import default_out, main
from sonarlog import read_log

ROOT = Path(__file__).resolve().parents[3]
WORLD = ROOT / "configs" / "worlds" / "lab.yaml"


def _plan(tmp: Path, steps: list[object], **over: object) -> Path:
    plan: dict[str, object] = {
        "name": "t",
        "sonars": [0, 2, 14, 1, 15],
        "baud": 38400,
        "steps": [{"define_pose": {"x": -0.75, "y": 0.0, "theta": 0, "turret": 90}}, *steps],
    }
    plan.update(over)
    p = tmp / "plan.yaml"
    p.write_text(yaml.safe_dump(plan))
    return p


def _url(name: str, **q: object) -> str:
    query = "&".join(f"{k}={v}" for k, v in {"world": WORLD, "fast": 1, **q}.items())
    return f"nomad://{name}?{query}"


def test_run_in_process_with_notify(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    sock_path = tmp_path / "notify.sock"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(sock_path))
    sock.settimeout(0.1)
    monkeypatch.setenv("NOTIFY_SOCKET", str(sock_path))
    monkeypatch.setenv("WATCHDOG_USEC", "200000")
    monkeypatch.setenv("JOURNAL_STREAM", "8:1234")
    plan = _plan(tmp_path, [{"translate": {"distance": 0.1, "step": 0.05, "speed": 0.2}}])
    out = tmp_path / "a.h5"
    msgs: list[str] = []
    done = threading.Event()

    def drain() -> None:  # like systemd: read as they come (the queue holds a few only)
        while not done.is_set():
            with contextlib.suppress(TimeoutError):
                msgs.append(sock.recv(4096).decode())

    reader = threading.Thread(target=drain)
    reader.start()
    try:
        argv = ["--port", _url("cli-a"), "--plan", str(plan), "--out", str(out)]
        assert main([*argv, "--truth", str(WORLD)]) == 0
    finally:
        done.set()
        reader.join()
        # the datagrams sent before main returned are all queued on the socket (a unix
        # datagram send completes into the receiver's queue): read what the reader, which
        # a loaded machine may have kept off the CPU, left there, rather than wait for it
        sock.setblocking(False)
        with contextlib.suppress(BlockingIOError):
            while True:
                msgs.append(sock.recv(4096).decode())
        sock.close()
    assert msgs[0].startswith("READY=1")
    assert "WATCHDOG=1" in msgs
    assert msgs[-1].startswith("STOPPING=1\nSTATUS=plan completed")
    log = read_log(out)
    assert len(log.readings) > 20
    assert log.attrs["baud"] == 38400 and "translate" in log.attrs["plan"]
    assert np.isclose(log.readings["x"].max(), -0.65, atol=0.003)
    assert log.truth is not None and log.truth.shape[1] == 2 and len(log.truth) > 100


def test_usage_and_config_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert main(["--port", "x", "--plan", str(tmp_path / "none.yaml")]) == 2
    assert "none.yaml" in capsys.readouterr().err
    plan = _plan(tmp_path, [{"dwell": {"seconds": 0.1}}])
    existing = tmp_path / "exists.h5"
    existing.write_bytes(b"")
    assert main(["--port", "x", "--plan", str(plan), "--out", str(existing)]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err
    assert main(["--port", "x", "--plan", str(plan), "--out", str(tmp_path / "no/dir.h5")]) == 2
    assert main(["--port", "x", "--plan", str(plan), "--baud", "1234"]) == 2
    assert main(["--port", "x", "--plan", str(plan), "--truth", str(tmp_path / "w.yaml")]) == 2
    assert "--truth" in capsys.readouterr().err


def test_unreachable_port_is_a_runtime_failure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = _plan(tmp_path, [{"dwell": {"seconds": 0.1}}])
    out = tmp_path / "b.h5"
    assert main(["--port", str(tmp_path / "ttyGONE"), "--plan", str(plan), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    # one ERROR line: what failed, which port, the OS reason
    assert len(err) == 1 and " ERROR sonard: cannot open robot port " in err[0]
    assert err[0].endswith(f"{tmp_path / 'ttyGONE'}: No such file or directory")
    # a run that failed before its first reading leaves no log: the retry is not refused
    assert not out.exists()
    assert main(["--port", str(tmp_path / "ttyGONE"), "--plan", str(plan), "--out", str(out)]) == 1
    assert "refusing" not in capsys.readouterr().err


def test_unreachable_url_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = _plan(tmp_path, [{"dwell": {"seconds": 0.1}}])
    out = tmp_path / "u.h5"
    assert main(["--port", "nomad://?world=gone.yaml", "--plan", str(plan), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ERROR sonard: cannot reach the robot on nomad://" in err[0]
    assert not out.exists()


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("sonard ")


def test_fault_timeout_aborts_cleanly(tmp_path: Path) -> None:
    """The link vanishes for longer than --fault-timeout: exit 1, events and a valid log."""
    plan = _plan(tmp_path, [{"dwell": {"seconds": 30}}])
    out = tmp_path / "c.h5"
    url = _url("cli-c", unplug_at=1.5, unplug_for=30, fast=0)
    rc = main(["--port", url, "--plan", str(plan), "--out", str(out), "--fault-timeout", "0.5"])
    assert rc == 1
    log = read_log(out)
    kinds = [e["kind"].decode() for e in log.events]
    assert "fault" in kinds and "abort" in kinds and kinds[-1] == "stop"
    assert len(log.readings) > 0


def test_default_out_uses_state_directory(tmp_path: Path) -> None:
    now = dt.datetime(2026, 11, 22, 3, 4, 5, tzinfo=dt.timezone.utc)
    assert default_out({"STATE_DIRECTORY": str(tmp_path)}, now) == (
        tmp_path / "sonard-20261122T030405Z.h5"
    )
    assert default_out({}, now).parent == Path.cwd()
