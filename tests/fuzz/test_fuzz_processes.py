"""A few damaged inputs through the real executables: what a user's shell sees.

The in-process fuzz tests (``test_fuzz_inputs.py``) cover hundreds of mutations through
``main(argv)``; these run the console entry points as processes, so interpreter start-up,
logging set-up and exit codes are the ones a user gets.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"
SONARPROC = [sys.executable, "-c", "import sys; from sonarproc.cli import main; sys.exit(main())"]
SONARD = [sys.executable, "-m", "sonard"]

pytestmark = [pytest.mark.timeout(300), pytest.mark.slow]


def _run(cmd: list[str]) -> subprocess.CompletedProcess[str]:
    # generous: interpreter start-up and imports take seconds on a loaded 2-core machine
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)


def _check(res: subprocess.CompletedProcess[str], out: Path, code: int) -> None:
    assert res.returncode == code, res.stderr
    assert "Traceback" not in res.stderr + res.stdout
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert 1 <= len(lines) <= 2, res.stderr
    assert not out.exists() or (out.is_dir() and not any(out.iterdir()))


def test_damaged_files_through_the_executables(tmp_path: Path) -> None:
    # a readings CSV whose first data row has a word for a time of flight
    lines = (CONFIGS / "sensors" / "example-readings.csv").read_text().splitlines()
    first = next(i for i, ln in enumerate(lines) if ln and not ln.startswith(("#", "t,")))
    cells = lines[first].split(",")
    cells[3] = "abc"
    lines[first] = ",".join(cells)
    csv = tmp_path / "bad.csv"
    csv.write_text("\n".join(lines) + "\n")
    out = tmp_path / "report"
    sensors = str(CONFIGS / "sensors" / "example-sensors.yaml")
    res = _run([*SONARPROC, "run", str(csv), "--sensors", sensors, "--out", str(out)])
    _check(res, out, 2)

    # a sonarlog cut after its first 2 KiB: the superblock, nothing of the tables
    log = tmp_path / "log.h5"
    good_csv = str(CONFIGS / "sensors" / "example-readings.csv")
    from sonarlog.csvlog import read_csv_log
    from sonarlog.sources.dispatch import write_sonarlog

    write_sonarlog(read_csv_log(good_csv, sensors), log)
    data = log.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[:2048])
    out = tmp_path / "cut.out.h5"
    res = _run([*SONARPROC, "import", str(cut), "--out", str(out)])
    assert res.returncode in (1, 2), res.stderr
    _check(res, out, res.returncode)

    # a Player log that is not one
    player = tmp_path / "run.log"
    player.write_text("## Player version 3.0.2\n1700000000.0 a b sonar 0 1 1 nan inf\n")
    out = tmp_path / "player.h5"
    res = _run([*SONARPROC, "import", str(player), "--out", str(out)])
    assert res.returncode in (1, 2), res.stderr
    _check(res, out, res.returncode)

    # a plan with an angle where a list of sonars belongs
    plan = tmp_path / "plan.yaml"
    plan.write_text(
        (CONFIGS / "plans" / "translate.yaml").read_text().replace("[0, 2, 14, 1, 15]", "90")
    )
    out = tmp_path / "run.h5"
    res = _run(
        [*SONARD, "--port", str(tmp_path / "no-tty"), "--plan", str(plan), "--out", str(out)]
    )
    _check(res, out, 2)
    assert "sonars" in res.stderr
