"""The command line runs numpy's BLAS on one thread unless the user asked for more."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = (
    "import sonarproc.cli.entry, os\n"
    "import numpy\n"
    "print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['OMP_NUM_THREADS'])\n"
)


def _probe(env: dict[str, str]) -> list[str]:
    out = subprocess.run(
        [sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True
    )
    return out.stdout.split()


@pytest.mark.parametrize("user", [None, "3"])
def test_one_blas_thread_unless_the_user_set_it(user: str | None) -> None:
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    if user is not None:
        env["OPENBLAS_NUM_THREADS"] = user
    openblas, omp = _probe(env)
    assert openblas == (user or "1")
    assert omp == "1"


def test_numpy_is_not_loaded_before_the_cli_package_sets_the_threads() -> None:
    # OpenBLAS reads the variable once, when numpy loads it
    probe = "import sonarproc, sonarproc.cli, sys; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
