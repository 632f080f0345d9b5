"""nomad-emulator: exit codes and the trace over a real pty."""

from __future__ import annotations

import json
import math
import signal
from pathlib import Path

import pytest
from procs import stop_process

from nomad200 import BAUD_RATES, Client, StateMask
from nomad200.emulator_cli import main
from nomad200.protocol_nomad import URL_KEYS, parse_url

from .conftest import nomad_url, start_emulator


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
        ["--world", "lab", "--baud", "1234"],
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


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``main(argv)`` -> exit code, stdout, stderr (argparse exits count as returns)."""
    try:
        code = main(argv)
    except SystemExit as e:
        code = int(e.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def test_bad_baud_names_the_allowed_speeds(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(["--world", "lab", "--baud", "1234"], capsys)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "1234" in err and all(str(b) in err for b in BAUD_RATES)


@pytest.mark.parametrize(
    ("flag", "path", "words"),
    [
        ("--link", "/nonexist/dir/tty", ["--link /nonexist/dir/tty", "/nonexist/dir", "exist"]),
        ("--trace", "/nonexist/dir/t.jsonl", ["--trace /nonexist/dir/t.jsonl", "No such"]),
    ],
)
def test_bad_paths_give_one_clear_line(
    flag: str, path: str, words: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run(["--world", "lab", flag, path], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("nomad-emulator: error: ") and all(w in err for w in words)
    assert "->" not in err and "Errno" not in err


def test_help_is_plain_text_and_explains_the_url(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["--help"], capsys)
    assert code == 0
    description = out.split("\n\n")[1]
    assert description.startswith("An emulated Nomad 200")
    assert "``" not in out and ":mod:" not in out and ":class:" not in out
    assert "nomad://[NAME]?KEY=VALUE" in out and "serial_for_url" in out
    assert all(f"{key}=" in out for key in URL_KEYS)
    assert "nomad://?world=lab&fast=1&baud=38400" in out


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["--version"], capsys)
    assert code == 0 and out.startswith("nomad-emulator ") and out.count("\n") == 1
    assert out.split()[1][0].isdigit()


def test_shipped_world_by_name(tmp_path: Path) -> None:
    link, proc = start_emulator(tmp_path, world="lab", fast=True, baud=38400)
    try:
        with Client(link, baud=38400) as c:
            st = c.configure_mask(StateMask(pose=True))
            assert (st.x, st.y) == (0.0, 0.0)
    finally:
        stop_process(proc)


def test_url_takes_a_shipped_world_and_refuses_other_speeds() -> None:
    assert parse_url("nomad://?world=lab&fast=1")[1].world == "lab"
    with pytest.raises(ValueError, match="allowed 4800, 9600, 19200, 38400"):
        parse_url("nomad://?baud=1234")
    url = nomad_url(world="lab", fast=True, baud=38400)
    with Client(url, baud=38400) as c:
        c.configure_mask(StateMask(sonars=frozenset(range(16))))
        c.configure_sonars(range(16), 0.04)
        seen = set()
        for _ in range(60):  # ~1 s of robot time
            seen |= {i for i, r in c.get_state().sonar.items() if r is not None}
    assert len(seen) >= 4  # the lab's walls answer; an empty world would not
