"""The ``sonarproc`` command line: a thin typer layer over the library.

``app`` holds the typer app and the error policy; one module per subcommand (``run``,
``batch``, ``compare``, ``export``, ``recover``, ``simulate``, ``sweep``, ``watch``) parses its
options and calls the library; ``options`` holds the options they share; ``entry`` runs it all
(not named ``main``: importing a submodule of that name would replace this package's
:func:`main` function with the module).
"""

from __future__ import annotations

import os

# One BLAS thread per process unless the user set the variable: the commands' linear
# algebra is on small matrices (spline knots, per-point least squares, a pose graph of a
# few hundred unknowns), where a BLAS thread pool costs more in hand-over than it saves,
# and on a busy robot PC its spinning threads fight the other processes for the cores (a
# 64 x 64 eigh measured 1 ms with one thread, 120 ms with OpenBLAS's pool on a loaded
# 2-core machine). Set here, before any command imports numpy and numpy loads the library;
# sweep and batch workers inherit it.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default: ``sys.argv[1:]``) and return the exit code."""
    from sonarproc.cli.entry import main as run_main

    return run_main(argv)
