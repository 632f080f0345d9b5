"""The ``sonarproc`` command line: a thin typer layer over the library.

``app`` holds the typer app and the error policy; one module per subcommand (``run``,
``compare``, ``export``, ``recover``, ``simulate``, ``sweep``, ``watch``) parses its options
and calls the library; ``options`` holds the options they share; ``main`` runs it all.
"""

from __future__ import annotations

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default: ``sys.argv[1:]``) and return the exit code."""
    from sonarproc.cli.main import main as run_main

    return run_main(argv)
