"""The product as a user installs it: a wheel in a fresh venv, run outside the repository.

Builds the wheel (``pip wheel``), installs it without dependencies into a new venv whose
only other path is the test venv's site-packages (for numpy, h5py, ...; not the editable
install, whose finder lives in a ``.pth`` that a plain path entry does not run), and runs
every command by shipped names from an empty directory: ``simulate fig12``, ``run``,
``compare``, the studies, and ``sonard`` against the ``nomad://`` emulator.
"""

from __future__ import annotations

import json
import site
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("wheel")
    wheels = base / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels), str(ROOT)],
        check=True,
        cwd=base,
    )
    (wheel,) = wheels.glob("sonarmorph-*.whl")
    env_dir = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True)
    purelib = Path(
        sysconfig.get_path("purelib", vars={"base": str(env_dir), "platbase": str(env_dir)})
    )
    purelib.mkdir(parents=True, exist_ok=True)
    (purelib / "test-deps.pth").write_text(
        "\n".join(site.getsitepackages()) + "\n", encoding="utf-8"
    )
    subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(env_dir / "bin" / "python"), "install",
         "-q", "--no-deps", str(wheel)],
        check=True,
    )  # fmt: skip
    return env_dir


def run(venv: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run(
        [str(venv / "bin" / args[0]), *args[1:]],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    return proc


def test_the_installed_package_is_not_the_checkout(venv: Path, tmp_path: Path) -> None:
    proc = run(venv, tmp_path, "python", "-c", "import sonarproc, sonarsim; "
               "print(sonarproc.__file__); print(sonarsim.__file__)")  # fmt: skip
    for line in proc.stdout.split():
        assert str(venv) in line and str(ROOT) not in line


def test_commands_by_shipped_names(venv: Path, tmp_path: Path) -> None:
    run(venv, tmp_path, "sonarproc", "simulate", "fig13", "--out", "fig13.h5")
    run(venv, tmp_path, "sonarproc", "run", "fig13.h5", "--ops", "thinning:3", "--order", "10")
    doc = json.loads((tmp_path / "fig13_report" / "report.json").read_text())
    assert doc["metrics"]["E1_m"] is not None and doc["counts"]["readings_used"] > 10
    run(venv, tmp_path, "sonarproc", "compare", "fig13.h5", "--methods",
        "morphological,line-of-sight", "--out", "cmp")  # fmt: skip
    assert json.loads((tmp_path / "cmp" / "compare.json").read_text())["methods"]
    for cmd in (["sonarproc", "--version"], ["sonard", "--version"]):
        assert "0." in run(venv, tmp_path, *cmd).stdout


def test_sonard_against_the_url_emulator(venv: Path, tmp_path: Path) -> None:
    run(venv, tmp_path, "sonard", "--port", "nomad://?world=lab&fast=1", "--plan",
        "turret-sweep", "--out", "sweep.h5")  # fmt: skip
    count = "from sonarlog import read_log; print(len(read_log('sweep.h5').readings))"
    proc = run(venv, tmp_path, "python", "-c", count)
    assert int(proc.stdout) > 50


def test_studies_write_where_told(venv: Path, tmp_path: Path) -> None:
    out = tmp_path / "docs"
    out.mkdir()
    run(venv, tmp_path, "python", "-m", "sonarmorph_tools.noise_sweep", "--out-dir", str(out),
        "--jobs", "1", "--seeds", "2")  # fmt: skip
    assert (out / "noise-sweep.md").stat().st_size > 200 and (out / "fig14.png").is_file()
    run(venv, tmp_path, "python", "-m", "sonarmorph_tools.reproduce", "--out",
        str(out / "reproduction.md"))  # fmt: skip
    text = (out / "reproduction.md").read_text()
    assert "fig13" in text and "fig02" in text and len(text) > 2000
