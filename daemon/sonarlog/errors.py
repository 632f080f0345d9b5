"""The sonarlog exception tree.

::

    SonarLogError                     root of everything this package raises
    └── InvalidLogError (ValueError)  the file is not a usable sonarlog v1 (user-facing, exit 2)
"""

from __future__ import annotations


class SonarLogError(Exception):
    """Root of the sonarlog exception tree."""


class InvalidLogError(SonarLogError, ValueError):
    """A file that is not a readable sonarlog v1; the message names the file and the problem."""
