"""The errors of reading robot logs (ROS bags, Player logs) into a sonarlog.

::

    SonarLogError                           sonarlog's root
    └── SourceError (ValueError)            a log that cannot be imported: the one-line
        │                                   message names the file and what is missing
        └── OutputExistsError (FileExistsError)
                                            the output exists and ``force`` was not given

Every message is one line that starts with the path of the file concerned, so a command
line tool can print it as it is and exit with status 2.
"""

from __future__ import annotations

from sonarlog.errors import SonarLogError

__all__ = ["OutputExistsError", "SourceError"]


class SourceError(SonarLogError, ValueError):
    """A robot log that cannot be imported (no sonar topic, no odometry, truncated, ...)."""


class OutputExistsError(SourceError, FileExistsError):
    """The output file or bag exists already and overwriting was not asked for."""
