"""Check output paths before any work: one line naming the flag, the path and the fix.

A run that fails at its last step because ``--out`` names a file, or a directory that
does not exist, wastes the run and says so in the words of the OS (``[Errno 17]``) or of
HDF5. These checks run first and raise :class:`~sonarproc.errors.ParameterError` for the
flag, which :func:`sonarproc.cli.app.guarded` prints as one line with exit code 2.
"""

from __future__ import annotations

from pathlib import Path

from sonarproc.errors import ParameterError

__all__ = ["check_input", "check_output_dir", "check_output_file"]


def _first_existing(path: Path) -> Path:
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_output_dir(path: Path, parameter: str = "out") -> None:
    """``path`` can be (or already is) a directory that the command writes into."""
    if path.exists() and not path.is_dir():
        raise ParameterError(
            parameter, f"{path} is a file; give a directory (it is created if missing)"
        )
    base = _first_existing(path)
    if not base.is_dir():
        raise ParameterError(parameter, f"{path}: {base} is a file, not a directory")


def check_output_file(path: Path, parameter: str = "out", *, overwrite: bool = True) -> None:
    """``path`` can be written as a file: not a directory, in a directory that exists."""
    if path.is_dir():
        raise ParameterError(parameter, f"{path} is a directory; give a file name")
    if path.exists() and not overwrite:
        raise ParameterError(parameter, f"{path} exists; choose another name or use --force")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.exists():
        raise ParameterError(parameter, f"{path}: directory {parent} does not exist")
    if not parent.is_dir():
        raise ParameterError(parameter, f"{path}: {parent} is a file, not a directory")


def check_input(path: Path, parameter: str, what: str) -> None:
    """``path`` is an existing file (``what`` says which kind, for the message)."""
    if not path.exists():
        raise ParameterError(parameter, f"{path}: no such file (expected {what})")
    if path.is_dir():
        raise ParameterError(parameter, f"{path} is a directory (expected {what})")
