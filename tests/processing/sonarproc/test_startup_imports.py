"""What a run loads before it works: only what its log needs.

``sonarproc run`` on a readings CSV never opens an HDF5 file, so h5py (and the
``uname`` subprocess its import starts) is not loaded; the allocator setting the command
makes first starts no subprocess (no ``ldconfig``). Each check runs in a fresh
interpreter, since this test process may have loaded anything.
"""

from __future__ import annotations

import platform
import subprocess
import sys
from pathlib import Path

ROBOND = Path(__file__).resolve().parents[2] / "data" / "real" / "robond"

# Reads the shipped CSV log as `run` does, then says which of the modules are loaded.
_READ_CSV = """
import sys
import sonarproc.cli.entry, sonarproc.report, sonarproc.run_modes
from sonarproc.pipeline import load_log
log = load_log(sys.argv[1], sensors=sys.argv[2])
print(log.readings.size, "h5py" in sys.modules)
"""

# The allocator setting, with every subprocess the interpreter would start refused.
_NO_SUBPROCESS = """
import subprocess
def refuse(*args, **kwargs):
    raise AssertionError(f"a subprocess was started: {args}")
subprocess.Popen.__init__ = refuse
from sonarproc.runtime import retain_freed_memory
print(retain_freed_memory())
"""


def _python(code: str, *args: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, check=True
    )
    return out.stdout.strip()


def test_reading_a_csv_log_does_not_load_h5py() -> None:
    readings, loaded = _python(
        _READ_CSV, str(ROBOND / "readings.csv"), str(ROBOND / "sensors.yaml")
    ).split()
    assert readings == "3304"
    assert loaded == "False"


def test_the_allocator_setting_starts_no_subprocess() -> None:
    # glibc takes the setting; elsewhere it is declined, still without a subprocess
    glibc = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"
    assert _python(_NO_SUBPROCESS) == str(glibc)


# What a run with ``--fit polar`` loads for its quality stage and held-out folds.
_POLAR_STAGES = """
import sys
import sonarproc.quality, sonarproc.quality.ahead, sonarproc.auto.holdout
import sonarproc.methods
print(*(m in sys.modules for m in (
    "sonarproc.surfaces.extraction.extract", "sonarproc.auto.select", "scipy.optimize",
    "scipy.ndimage",
)))
"""


def test_the_polar_fit_stages_do_not_load_the_surface_fit() -> None:
    # the packages load their names on first use: a map method's SurfaceFit, or the
    # held-out folds, do not bring the surface extraction or --auto's selection with them
    assert _python(_POLAR_STAGES).split() == ["False"] * 4


def test_the_lazy_packages_still_give_every_public_name() -> None:
    code = (
        "import sonarproc.surfaces as s, sonarproc.auto as a\n"
        "print(all(getattr(p, n) is not None for p in (s, a) for n in p.__all__))"
    )
    assert _python(code) == "True"
