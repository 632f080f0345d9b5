"""Run the ``sonarproc`` command line: import every subcommand, run the app."""

from __future__ import annotations

import gc
import sys
from typing import NoReturn

import typer

from sonarproc.cli import (
    batch,
    compare,
    export,
    import_log,
    recover,
    run,
    simulate,
    sweep,
    watch,
)
from sonarproc.cli.app import app
from sonarproc.runtime import freeze_modules, retain_freed_memory

__all__ = ["main", "run_console"]

#: The subcommand modules (imported for their side effect of registering on ``app``).
COMMANDS = (batch, compare, export, import_log, recover, run, simulate, sweep, watch)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default: ``sys.argv[1:]``) and return the exit code.

    Usage errors (an unknown option, a missing argument, a value of the wrong type) are
    one line on stderr and exit code 2, like every other user mistake, instead of the
    usage box the parser would draw.
    """
    args = argv if argv is not None else sys.argv[1:]
    retain_freed_memory()
    try:
        code = app(args=args, prog_name="sonarproc", standalone_mode=False)
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except typer.Abort:
        print("sonarproc: interrupted", file=sys.stderr)
        return 130
    except typer.TyperException as err:
        ctx = getattr(err, "ctx", None)
        if not err.format_message().strip() and ctx is not None:  # no arguments: the help
            print(ctx.get_help())
        else:
            print(usage_message(err), file=sys.stderr)
        return int(getattr(err, "exit_code", 2))
    return code if isinstance(code, int) else 0


def usage_message(err: typer.TyperException) -> str:
    """``sonarproc run: error: <what> (see 'sonarproc run --help')`` on one line."""
    ctx = getattr(err, "ctx", None)
    where = ctx.command_path if ctx is not None else "sonarproc"
    text = " ".join(err.format_message().split())
    if text.startswith("Got unexpected extra argument"):
        text += "; flags such as --json take no value"
    return f"{where}: error: {text} (see '{where} --help')"


def run_console() -> NoReturn:  # pragma: no cover - console-script shim
    """Console-script entry point.

    The command's modules (a thousand of them, with scipy and matplotlib) live as long
    as the process: :func:`gc.freeze` takes them, and what is alive as the command ends,
    out of the collector's sight, so that neither its collections during the command nor
    the interpreter's at exit look at them again (at exit, about a fifth of a second on
    a run's modules and maps). Only the console script does: a host process calling
    :func:`main` keeps its collector as it is.
    """
    freeze_modules()  # and those a command loads later (sonarproc.runtime.loading_modules)
    code = main()
    gc.freeze()
    sys.exit(code)
