"""The exceptions sonarproc raises, one tree under :class:`SonarprocError`.

::

    SonarprocError
     +-- InputError (also ValueError)       a log or file the method cannot use
     |    +-- NothingToMapError             every reading skipped, no arc on the map
     +-- ParameterError (also ValueError)   a parameter outside what is allowed
     +-- FitError (also RuntimeError)       a fit was required and could not be made

Messages name the library's parameters (``cell``, ``ops``), never command-line flags;
:class:`ParameterError` carries the parameter's name so that a command line can say which
of its flags was wrong. Errors of the log format itself come from :mod:`sonarlog`
(:class:`sonarlog.SonarLogError`), of simulated worlds from :mod:`sonarsim`.
"""

from __future__ import annotations

__all__ = ["FitError", "InputError", "NothingToMapError", "ParameterError", "SonarprocError"]


class SonarprocError(Exception):
    """Root of every error sonarproc raises on purpose."""


class InputError(SonarprocError, ValueError):
    """A log, CSV or other input file that cannot be processed as it is."""


class NothingToMapError(InputError):
    """Nothing is left to map: every reading skipped, or no arc touches the map."""


class ParameterError(SonarprocError, ValueError):
    """A parameter value outside what is allowed.

    Parameters
    ----------
    parameter : str
        The parameter's name in the library (``cell``, ``ops``, ``order``...).
    problem : str
        What is wrong and what is allowed, e.g. ``"must be > 0 m, got -1"``.

    Examples
    --------
    >>> str(ParameterError("cell", "must be > 0 m, got -1"))
    'cell: must be > 0 m, got -1'
    """

    def __init__(self, parameter: str, problem: str) -> None:
        super().__init__(f"{parameter}: {problem}")
        self.parameter = parameter
        self.problem = problem


class FitError(SonarprocError, RuntimeError):
    """A fit that a caller required could not be made (the reason is in the message)."""
