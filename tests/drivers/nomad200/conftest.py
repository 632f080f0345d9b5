"""Fixtures: an emulated robot over a real pty (subprocess) or the nomad:// URL scheme."""

from __future__ import annotations

import itertools
import subprocess
import sys
import textwrap
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from procs import stop_process

import nomad200
from nomad200 import protocol_nomad

_PROCS: list[subprocess.Popen[str]] = []
_COUNTER = itertools.count()

BOX = """\
name: box
start_pose: {x: 0.0, y: 0.0, theta_deg: 0.0}
surfaces:
  - {type: room, x_min: -2.0, x_max: 2.0, y_min: -2.0, y_max: 3.0}
"""


@pytest.fixture(autouse=True)
def _no_leaks() -> Iterator[None]:
    """Fail a test that leaves a client, a nomad:// port or an emulator process open."""
    yield
    leaks: list[str] = []
    for c in nomad200.open_clients():
        leaks.append(f"client on {c.port}")
        c.close()
    for s in protocol_nomad.open_ports():
        leaks.append(f"nomad:// port {s.portstr}")
        s.close()
    for p in _PROCS:
        if p.poll() is None:
            leaks.append(f"emulator pid {p.pid}")
        stop_process(p)
    _PROCS.clear()
    protocol_nomad.reset_devices()
    if leaks:
        pytest.fail("test left open: " + ", ".join(leaks))


@pytest.fixture
def box_world(tmp_path: Path) -> Path:
    """A closed 4 m x 5 m room, robot at the origin facing +x."""
    p = tmp_path / "box.yaml"
    p.write_text(textwrap.dedent(BOX))
    return p


def start_emulator(tmp_path: Path, **opts: Any) -> tuple[str, subprocess.Popen[str]]:
    """Run ``nomad-emulator`` on a pty; return the --link path and the process."""
    link = tmp_path / f"nomad{next(_COUNTER)}"
    cmd = [sys.executable, "-m", "nomad200.emulator_cli", "--link", str(link)]
    for k, v in opts.items():
        flag = "--" + k.replace("_", "-")
        if v is True:
            cmd.append(flag)
        elif v is not False and v is not None:
            cmd += [flag, str(v)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    _PROCS.append(p)
    assert p.stdout is not None
    first = p.stdout.readline().strip()
    assert first.startswith("/dev/"), f"emulator said {first!r}"
    return str(link), p


def nomad_url(**opts: Any) -> str:
    """A ``nomad://`` URL for a fresh robot with these options."""
    q = [f"{k}={int(v) if isinstance(v, bool) else v}" for k, v in opts.items() if v is not None]
    return f"nomad://t{next(_COUNTER)}?" + "&".join(q)


PortFactory = Callable[..., str]


@pytest.fixture(params=["pty", "url"])
def make_port(request: pytest.FixtureRequest, tmp_path: Path) -> PortFactory:
    """Factory ``make_port(world=..., fast=..., baud=..., garble=..., ...) -> port``.

    The same tests run over a real pseudo-terminal (the ``nomad-emulator`` command in a
    subprocess) and over the in-process ``nomad://`` URL scheme.
    """

    mine: list[subprocess.Popen[str]] = []

    def make(**opts: Any) -> str:
        opts.setdefault("baud", 38400)
        if request.param == "pty":
            link, proc = start_emulator(tmp_path, **opts)
            mine.append(proc)
            return link
        return nomad_url(**opts)

    def stop_all() -> None:
        for p in mine:
            stop_process(p)

    request.addfinalizer(stop_all)
    return make
