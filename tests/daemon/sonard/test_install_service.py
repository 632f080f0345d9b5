"""scripts/install-service answers --help with a usage text, not its own source."""

from __future__ import annotations

import subprocess
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "install-service"


def test_help_is_a_usage_text() -> None:
    done = subprocess.run(
        ["bash", str(SCRIPT), "--help"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0
    assert done.stdout.startswith("Usage: install-service [OPTIONS]")
    assert "--dry-run" in done.stdout and "set -euo" not in done.stdout
    assert not any(line.startswith("#") for line in done.stdout.splitlines())


def test_unknown_option_is_a_usage_error() -> None:
    done = subprocess.run(
        ["bash", str(SCRIPT), "--bogus"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 2
    assert done.stderr.startswith("install-service: unknown option --bogus")
