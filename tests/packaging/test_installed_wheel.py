"""The product as a user installs it: a wheel in a fresh venv, run outside the repository.

Builds the wheel (``pip wheel``), installs it without dependencies into a new venv whose
only other path is the test venv's site-packages (for numpy, h5py, ...; not the editable
install, whose finder lives in a ``.pth`` that a plain path entry does not run), and runs
every command by shipped names from an empty directory: ``simulate fig12``, ``run``,
``compare``, and ``sonard`` against the ``nomad://`` emulator. The wheel holds the product
only: no tuning studies, no test scenarios, no ``tools/``; the documentation tools in
``tools/`` run against the installed packages.
"""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow


#: What the wheel is built from (pyproject's package folders, readme and licence).
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "drivers", "daemon", "processing")
#: The scenarios the wheel ships: the paper's figures and the multi-surface scenes.
SHIPPED_SCENARIOS = {
    "fig02", "fig06a", "fig06b", "fig08a", "fig08b", "fig10b", "fig10c", "fig12", "fig13",
    "fig16", "fig18", "corridor-l", "room-box", "hall-pillar",
    "office-door", "corridor-tee", "curved-room", "pioneer-hall",
}  # fmt: skip


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("wheel")
    # Built from a copy of the sources: setuptools reuses a checkout's build/lib, where files
    # deleted since an earlier build would still lie and be packed into the wheel.
    src = base / "src"
    skip = shutil.ignore_patterns("__pycache__", "*.egg-info", "build")
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=skip)
        else:
            src.mkdir(exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    wheels = base / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels), str(src)],
        check=True,
        cwd=base,
    )
    (built,) = wheels.glob("sonarmorph-*.whl")
    return built


@pytest.fixture(scope="module")
def venv(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    env_dir = tmp_path_factory.mktemp("venv") / "venv"
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


def run(
    venv: Path, cwd: Path, *args: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run(
        [str(venv / "bin" / args[0]), *args[1:]],
        cwd=cwd,
        env=None if env is None else {**os.environ, **env},
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


def test_the_wheel_holds_the_product_only(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/", 1)[0] for n in names if not n.split("/", 1)[0].endswith(".dist-info")}
    assert tops == {"nomad200", "sonarsim", "sonarlog", "sonard", "sonarproc"}
    assert not [n for n in names if "/studies/" in n or "sonarmorph_tools" in n]
    prefix = "sonarsim/data/scenarios/"
    scenarios = {Path(n).stem for n in names if n.startswith(prefix) and n.endswith(".yaml")}
    assert scenarios == SHIPPED_SCENARIOS
    # the worlds the shipped scenarios name ship too
    assert "sonarsim/data/worlds/paper-sinusoid.yaml" in names


def test_the_tools_run_against_the_installed_wheel(venv: Path, tmp_path: Path) -> None:
    out = tmp_path / "docs"
    out.mkdir()
    tools = {"PYTHONPATH": str(ROOT / "tools")}
    run(venv, tmp_path, "python", "-m", "sonarmorph_tools.noise_sweep", "--out-dir", str(out),
        "--jobs", "1", "--seeds", "2", env=tools)  # fmt: skip
    assert (out / "noise-sweep.md").stat().st_size > 200 and (out / "fig14.png").is_file()
    run(venv, tmp_path, "python", "-m", "sonarmorph_tools.reproduce", "--out",
        str(out / "reproduction.md"), "--only", "fig13", "--only", "fig02", "--no-ring-log",
        "--quiet", env=tools)  # fmt: skip
    text = (out / "reproduction.md").read_text()
    assert "fig13" in text and "fig02" in text and len(text) > 2000
