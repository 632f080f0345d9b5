"""nomad-emulator: exit codes and the trace over a real pty."""

from __future__ import annotations

import json
import math
import signal
from pathlib import Path

import pytest
from procs import stop_process

from nomad200 import Client, StateMask
from nomad200.emulator_cli import main

from .conftest import start_emulator


def test_bad_world_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--world", str(tmp_path / "missing.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot load world" in err
    bad = tmp_path / "bad.yaml"
    bad.write_text("surfaces: [{type: teapot}]\n")
    assert main(["--world", str(bad)]) == 2


@pytest.mark.parametrize(
    "argv",
    [
        ["--world", "w.yaml", "--garble", "2"],
        ["--world", "w.yaml", "--drop-rx", "-0.5"],
        ["--world", "w.yaml", "--garble-rx", "nan"],
        ["--bogus"],
        [],
    ],
)
def test_bad_options_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    try:
        code = main(argv)
    except SystemExit as e:
        code = int(e.code or 0)
    assert code == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_help_tells_both_directions(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--garble-rx RATE" in text and "--drop-rx RATE" in text
    assert "per request byte (host to robot)" in text
    assert "per reply byte (robot to host)" in text


def test_trace_and_sigterm(tmp_path: Path, box_world: Path) -> None:
    trace = tmp_path / "trace.jsonl"
    link, proc = start_emulator(tmp_path, world=box_world, fast=True, baud=38400, trace=trace)
    try:
        with Client(link, baud=38400) as c:
            c.configure_mask(StateMask(sonars=frozenset({0}), pose=True))
            c.configure_sonars([0], 0.02)
            c.move_relative(0.2, 0.0, math.radians(30))
            st = c.wait_stopped(10)
            for _ in range(10):
                st = c.get_state()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(5) == 0
    finally:
        stop_process(proc)
    recs = [json.loads(line) for line in trace.read_text().splitlines()]
    cmds = [r["cmd"] for r in recs if r["type"] == "command"]
    assert cmds[:4] == ["CT", "CT", "CONF_SN", "PR"]
    fires = [r for r in recs if r["type"] == "firing"]
    assert fires and all(r["sonar"] == 0 for r in fires)
    last = fires[-1]
    assert last["odom"]["x"] == pytest.approx(st.x, abs=0.003)
    assert last["world"]["turret"] == pytest.approx(math.radians(30), abs=0.002)
    # box: wall at x = 2; sonar 0 at 30 deg: the wall is not normal to the beam -> 255, or
    # the true first echo range matches the reported inches
    assert last["raw"] == 255 or last["raw"] == round(last["echo_range_m"] / 0.0254)
