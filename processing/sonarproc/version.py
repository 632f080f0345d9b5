"""The installed distribution's version, in a module of its own.

Modules inside the package read it from here rather than from :mod:`sonarproc`, whose
``__init__`` re-exports the Python API: importing the package root from inside the
package would tie every module to the API and make an import cycle.
"""

from __future__ import annotations

from importlib import metadata

__all__ = ["__version__"]

try:
    __version__ = metadata.version("sonarmorph")
except metadata.PackageNotFoundError:  # pragma: no cover - running from an uninstalled tree
    __version__ = "0+unknown"
