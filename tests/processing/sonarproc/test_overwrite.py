"""Commands that write a log refuse to overwrite one unless given ``--force``."""

from __future__ import annotations

from pathlib import Path

import pytest

from sonarlog import read_log
from sonarproc.cli import main


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_simulate_refuses_then_forces(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "fig13.h5"
    assert main(["simulate", "fig13", "--out", str(out), "--seed", "1"]) == 0
    first = read_log(out).readings.copy()
    assert main(["simulate", "fig13", "--out", str(out), "--seed", "2"]) == 2
    assert "exists; choose another name or use --force" in one_error_line(capsys.readouterr().err)
    assert (read_log(out).readings == first).all()  # untouched
    assert main(["simulate", "fig13", "--out", str(out), "--seed", "2", "--force"]) == 0
    assert len(read_log(out).readings) > 0 and not (
        len(read_log(out).readings) == len(first) and (read_log(out).readings == first).all()
    )


def test_recover_refuses_then_forces(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "a.h5"
    assert main(["simulate", "fig13", "--out", str(log)]) == 0
    dest = tmp_path / "b.h5"
    dest.write_bytes(b"keep me")
    assert main(["recover", str(log), "--out", str(dest)]) == 2
    assert "exists; choose another name or use --force" in one_error_line(capsys.readouterr().err)
    assert dest.read_bytes() == b"keep me"
    assert main(["recover", str(log), "--out", str(dest), "--force"]) == 0
    assert len(read_log(dest).readings) == len(read_log(log).readings)
    assert main(["recover", str(log), "--out", str(tmp_path / "nope" / "x.h5")]) == 2
    assert "does not exist" in one_error_line(capsys.readouterr().err)
