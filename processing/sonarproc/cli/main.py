"""Run the ``sonarproc`` command line: import every subcommand, run the app."""

from __future__ import annotations

import sys
from typing import NoReturn

from sonarproc.cli import compare, export, import_log, recover, run, simulate, sweep, watch
from sonarproc.cli.app import app

__all__ = ["main", "run_console"]

#: The subcommand modules (imported for their side effect of registering on ``app``).
COMMANDS = (compare, export, import_log, recover, run, simulate, sweep, watch)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default: ``sys.argv[1:]``) and return the exit code."""
    try:
        app(args=argv if argv is not None else sys.argv[1:], prog_name="sonarproc")
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    return 0


def run_console() -> NoReturn:  # pragma: no cover - console-script shim
    """Console-script entry point."""
    sys.exit(main())
