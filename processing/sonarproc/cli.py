"""The ``sonarproc`` command line: a thin typer layer over the library.

Each subcommand lives in its own ``cli_<name>.py`` module and registers itself on
:data:`app`; this module only builds the app and owns the error-to-exit-code policy.

Exit codes: 0 success, 1 runtime failure, 2 usage or configuration error.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

import typer

app = typer.Typer(
    name="sonarproc",
    help="Turn sonar time-of-flight logs into arc maps, morphologically processed maps "
    "and fitted surface profiles.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root() -> None:
    """Sonar time-of-flight logs to arc maps, processed maps and fitted surface profiles."""


class UsageProblem(Exception):
    """A user mistake (bad file, bad option value): exit code 2, one line, no traceback."""


class RuntimeProblem(Exception):
    """A failure that is not the user's fault: exit code 1, one line, no traceback."""


def fail(message: str, code: int = 2) -> NoReturn:
    """Print ``sonarproc: error: <message>`` on stderr and exit with ``code``."""
    typer.echo(f"sonarproc: error: {message}", err=True)
    raise typer.Exit(code)


@contextmanager
def guarded() -> Iterator[None]:
    """Turn the library's user-facing exceptions into one line and an exit code.

    ``ValueError``-derived errors from the library (bad log, bad parameter) are usage or
    configuration errors (2); ``OSError`` and :class:`RuntimeProblem` are runtime failures (1).
    """
    from sonarlog import SonarLogError

    try:
        yield
    except typer.Exit:
        raise
    except (UsageProblem, SonarLogError, ValueError, KeyError) as err:
        fail(str(err) or type(err).__name__, 2)
    except FileNotFoundError as err:
        # Our own resolvers put a fuller sentence in strerror (shipped names to choose from).
        plain = not err.strerror or err.strerror == "No such file or directory"
        fail(f"{err.filename}: {'no such file' if plain else err.strerror}", 2)
    except (RuntimeProblem, OSError) as err:
        fail(str(err) or type(err).__name__, 1)


def _register_commands() -> None:
    # Imported for their side effect of adding commands to ``app``.
    from sonarproc import (  # noqa: F401
        cli_compare,
        cli_export,
        cli_recover,
        cli_run,
        cli_simulate,
        cli_sweep,
        cli_watch,
    )


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default: ``sys.argv[1:]``) and return the exit code."""
    _register_commands()
    try:
        app(args=argv if argv is not None else sys.argv[1:], prog_name="sonarproc")
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    return 0


def run() -> NoReturn:  # pragma: no cover - console-script shim
    """Console-script entry point."""
    sys.exit(main())
