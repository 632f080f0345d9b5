"""sonarproc: sonar time-of-flight logs to arc maps, processed maps and surface profiles.

The layers, from the log to the report: :mod:`sonarproc.arcs` (arc geometry and
rasterisation), :mod:`sonarproc.morphology` (the operations on the map),
:mod:`sonarproc.fit` and :mod:`sonarproc.metrics`, :mod:`sonarproc.pipeline` (the one seam
every map goes through: select, grid, build, fit, measure; live processing),
:mod:`sonarproc.methods` (other ways to build the map), :mod:`sonarproc.report`
(files and figures), :mod:`sonarproc.sweep` and :mod:`sonarproc.cli`.
Errors: :mod:`sonarproc.errors`.
"""

from __future__ import annotations

from importlib import metadata

try:
    __version__ = metadata.version("sonarmorph")
except metadata.PackageNotFoundError:  # pragma: no cover - running from an uninstalled tree
    __version__ = "0+unknown"

__all__ = ["__version__"]
