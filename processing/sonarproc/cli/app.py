"""The ``sonarproc`` typer app and its error policy: which errors are the user's.

Each subcommand lives in its own module of this package and registers itself on
:data:`app`; :mod:`sonarproc.cli.entry` imports them all and runs the app.

Exit codes: 0 success, 1 runtime failure, 2 usage or configuration error. Only the
project's own errors (:class:`sonarproc.errors.SonarprocError`, the log format's
:class:`sonarlog.SonarLogError`, the simulator's world and scenario errors) and
``OSError`` become one line and an exit code; anything else is a bug and keeps its
traceback (exit 1).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, NoReturn

import typer

from sonarproc.errors import FitError, ParameterError, SonarprocError
from sonarproc.version import __version__

if TYPE_CHECKING:
    from sonarlog import SonarLog

__all__ = [
    "PARAMETER_FLAGS",
    "RuntimeProblem",
    "app",
    "fail",
    "guarded",
    "version_callback",
    "warn_if_damaged",
]


def _flags_show_as_flags() -> None:
    """Show on/off flags bare in ``--help`` (``--json``), not as ``--json <bool>``.

    This typer prints every option's type, flags included, which reads as if ``--json``
    took a value (and ``--json true`` is then refused). Flags take none: show no type.
    """
    from typer import core

    option = getattr(core, "TyperOption", None)
    original = getattr(option, "display_type_rich", None)
    if option is None or original is None or getattr(original, "_flag_aware", False):
        return

    def display_type_rich(self: Any, ctx: Any) -> str | None:
        if getattr(self, "is_flag", False):
            return None
        result: str | None = original(self, ctx)
        return result

    display_type_rich._flag_aware = True  # type: ignore[attr-defined]
    option.display_type_rich = display_type_rich


_flags_show_as_flags()

app = typer.Typer(
    name="sonarproc",
    help="Turn sonar time-of-flight logs into arc maps, morphologically processed maps "
    "and fitted surface profiles.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

#: The command-line flag of each library parameter named in a :class:`ParameterError`.
PARAMETER_FLAGS = {
    "cell": "--cell",
    "bbox": "--bbox",
    "ops": "--ops",
    "fit": "--fit",
    "order": "--order",
    "smooth": "--smooth",
    "centre": "--centre",
    "robust": "--robust",
    "span": "--span",
    "arc_step": "--arc-step",
    "sensors": "--sensors",
    "truth": "--truth",
    "robot": "--robot",
    "formats": "--format",
    "method": "--method",
    "methods": "--methods",
    "settings": "--set",
    "grid": "--grid",
    "shard": "--shard",
    "seed": "--seed",
    "out": "--out",
    "jobs": "--jobs",
    "workers": "--workers (--jobs)",
    "engine": "--engine",
    "figures": "--figures",
}


def version_callback(value: bool) -> None:
    """Print the version and exit (``--version``)."""
    if value:
        typer.echo(f"sonarproc (sonarmorph) {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=version_callback, is_eager=True, help="Print the version."
    ),
) -> None:
    """Sonar time-of-flight logs to arc maps, processed maps and fitted surface profiles."""


class RuntimeProblem(SonarprocError):
    """A failure of a command that is not the user's fault: exit code 1, one line."""


def warn_if_damaged(log: SonarLog) -> None:
    """Print the one-line warning of a crashed or cut log (nothing for a closed one)."""
    warning = log.integrity_warning()
    if warning is not None:
        typer.echo(f"sonarproc: warning: {warning}", err=True)


def fail(message: str, code: int = 2) -> NoReturn:
    """Print ``sonarproc: error: <message>`` on stderr and exit with ``code``."""
    typer.echo(f"sonarproc: error: {message}", err=True)
    raise typer.Exit(code)


def flag_message(err: ParameterError) -> str:
    """The error's message with the library parameter replaced by its flag.

    Examples
    --------
    >>> flag_message(ParameterError("cell", "must be > 0 m, got -1"))
    '--cell: must be > 0 m, got -1'
    """
    flag = PARAMETER_FLAGS.get(err.parameter)
    if flag is None and err.parameter.replace("-", "").isalpha():
        flag = f"--set {err.parameter}.OPTION"  # a method's own option (histogram, ...)
    return f"{flag or err.parameter}: {err.problem}"


def os_message(err: OSError) -> str:
    """One line for an OS error: the file, then what went wrong, without ``[Errno N]``.

    HDF5's errors carry no file name; the path is taken from their message.

    Examples
    --------
    >>> os_message(FileExistsError(17, "File exists", "README.md"))
    'README.md: file exists'
    >>> os_message(OSError("Unable to create file (unable to open file: name = "
    ...     "'/no/x.h5.partial', errno = 2, error message = 'No such file or directory')"))
    '/no/x.h5: no such file or directory'
    """
    if err.filename is None and not err.strerror:
        import re

        text = str(err)
        named = re.search(r"name = '([^']*)'", text)
        reason = re.search(r"error message = '([^']*)'", text)
        if named:
            path = named.group(1).removesuffix(".partial")
            return f"{path}: {(reason.group(1) if reason else text).lower()}"
    name = err.filename if err.filename is not None else ""
    if isinstance(err, FileNotFoundError):
        # Our own resolvers put a fuller sentence in strerror (shipped names to choose from).
        plain = not err.strerror or err.strerror == "No such file or directory"
        return f"{name}: {'no such file' if plain else err.strerror}"
    what = (err.strerror or str(err)).rstrip(".").lower() if err.strerror else str(err)
    if err.filename2 is not None:
        return f"{name} -> {err.filename2}: {what}"
    return f"{name}: {what}" if name else what


def is_simulator_error(err: BaseException) -> bool:
    """Whether ``err`` is a world or scenario error of :mod:`sonarsim`.

    The simulator is imported only by the commands that simulate; when it was never
    imported, no error can be one of its own (and ``run`` does not pay for its import).
    """
    sim = sys.modules.get("sonarsim")
    return sim is not None and isinstance(err, (sim.ScenarioError, sim.WorldError))


@contextmanager
def guarded() -> Iterator[None]:
    """Turn the project's own errors and ``OSError`` into one line and an exit code.

    Parameter and input errors, log-format errors and simulator world/scenario errors are
    usage or configuration errors (2); a missing input file is too. Fit errors, other
    ``OSError`` and :class:`RuntimeProblem` are runtime failures (1). Any other exception
    is a bug: it propagates with its traceback.
    """
    from sonarlog import SonarLogError

    try:
        yield
    except typer.Exit:
        raise
    except ParameterError as err:
        fail(flag_message(err), 2)
    except (FitError, RuntimeProblem) as err:
        fail(str(err) or type(err).__name__, 1)
    except (SonarprocError, SonarLogError) as err:
        fail(str(err) or type(err).__name__, 2)
    except ValueError as err:
        if not is_simulator_error(err):
            raise
        fail(str(err) or type(err).__name__, 2)
    except FileNotFoundError as err:
        fail(os_message(err), 2)
    except IsADirectoryError as err:
        fail(f"{err.filename}: is a directory", 2)
    except OSError as err:
        fail(os_message(err), 1)
