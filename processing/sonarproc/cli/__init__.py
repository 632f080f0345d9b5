"""The ``sonarproc`` command line: a thin typer layer over the library.

``app`` holds the typer app and the error policy; one module per subcommand (``run``,
``batch``, ``compare``, ``export``, ``recover``, ``simulate``, ``sweep``, ``watch``) parses its
options and calls the library; ``options`` holds the options they share; ``entry`` runs it all
(not named ``main``: importing a submodule of that name would replace this package's
:func:`main` function with the module).
"""

from __future__ import annotations

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default: ``sys.argv[1:]``) and return the exit code."""
    from sonarproc.cli.entry import main as run_main

    return run_main(argv)
