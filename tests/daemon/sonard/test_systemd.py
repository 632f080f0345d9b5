"""The systemd units: `systemd-analyze verify` and an offline security score <= 2.0."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
UNITS = ROOT / "systemd"
ANALYZE = shutil.which("systemd-analyze")

pytestmark = pytest.mark.skipif(ANALYZE is None, reason="systemd-analyze not installed")


def _copy(unit: str, tmp_path: Path) -> Path:
    """The unit with ExecStart pointing at a binary that exists here (verify needs one)."""
    text = (UNITS / unit).read_text()
    assert "ExecStart=/usr/local/bin/sonard " in text
    dest = tmp_path / unit
    dest.write_text(text.replace("/usr/local/bin/sonard", "/bin/true"))
    return dest


def _analyze(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    assert ANALYZE is not None
    return subprocess.run(
        [ANALYZE, *args], cwd=cwd, capture_output=True, text=True, timeout=60, check=False
    )


@pytest.mark.parametrize(
    ("unit", "name"),
    [("sonard.service", "sonard.service"), ("sonard@.service", "sonard@ttyUSB0.service")],
)
def test_verify(unit: str, name: str, tmp_path: Path) -> None:
    _copy(unit, tmp_path)
    res = _analyze("verify", f"./{name}", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "sonard" not in res.stderr, res.stderr  # no warnings about our unit


@pytest.mark.parametrize(
    ("unit", "name"),
    [("sonard.service", "sonard.service"), ("sonard@.service", "sonard@ttyUSB0.service")],
)
def test_security_exposure_at_most_2(unit: str, name: str, tmp_path: Path) -> None:
    _copy(unit, tmp_path)
    res = _analyze("security", "--offline=yes", f"./{name}", cwd=tmp_path)
    m = re.search(r"Overall exposure level for \S+: (\d+(?:\.\d+)?)", res.stdout)
    assert m, res.stdout + res.stderr
    exposure = float(m.group(1))
    print(f"{name}: exposure {exposure}")
    assert exposure <= 2.0


def test_unit_settings() -> None:
    text = (UNITS / "sonard.service").read_text()
    for line in (
        "Type=notify",
        "Restart=on-failure",
        "DynamicUser=yes",
        "SupplementaryGroups=dialout",
        "StateDirectory=sonard",
        "RestartPreventExitStatus=2",
    ):
        assert re.search(rf"^{re.escape(line)}$", text, re.M), line
    assert re.search(r"^WatchdogSec=\d+$", text, re.M)
    assert "--plan" in text and "--port" in text
