"""The benchmarks' session: the packages byte-compiled before any run is timed.

Every benchmark times fresh interpreters, start-up and imports included. An installed
package is byte-compiled as it is installed; this checkout is installed in place, and in a
shell that sets ``PYTHONDONTWRITEBYTECODE`` no run writes the bytecode it compiles, so
every timed run would compile the package's changed sources again (about 0.15 s a run,
a cost no installed copy has). Compiling them once here times the package as installed.
"""

from __future__ import annotations

import compileall
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("drivers", "daemon", "processing")


@pytest.fixture(scope="session", autouse=True)
def byte_compiled() -> None:
    """Write the packages' bytecode where the interpreter looks for it (``__pycache__``)."""
    for name in PACKAGES:
        compileall.compile_dir(ROOT / name, quiet=1)
