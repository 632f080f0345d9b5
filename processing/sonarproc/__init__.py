"""sonarproc: sonar time-of-flight logs to arc maps, processed maps and surface profiles.

The layers, from the log to the report: :mod:`sonarproc.arcs` (arc geometry and
rasterisation), :mod:`sonarproc.morphology` (the operations on the map),
:mod:`sonarproc.fit` and :mod:`sonarproc.metrics`, :mod:`sonarproc.pipeline` (the one seam
every map goes through: select, grid, build, fit, measure; live processing),
:mod:`sonarproc.methods` (other ways to build the map), :mod:`sonarproc.report`
(files and figures), :mod:`sonarproc.sweep` and :mod:`sonarproc.cli`.
Errors: :mod:`sonarproc.errors`.

The Python API (:mod:`sonarproc.api`, imported on first use so that ``import sonarproc``
stays cheap)::

    import sonarproc
    r = sonarproc.run("fig12.h5")       # sonarproc run's options by name: fit="poly", ...
    r.metrics, r.profile, r.surfaces, r.figure("fit")
    sonarproc.compare("room.h5", methods=["morphological", "arc-median"])
    sonarproc.read_log("readings.csv", sensors="sensors.yaml")
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from sonarproc.version import __version__

if TYPE_CHECKING:
    from sonarproc.api import RunResult, compare, read_log, run

__all__ = ["RunResult", "__version__", "compare", "read_log", "run"]

_API = frozenset({"RunResult", "compare", "read_log", "run"})


def __getattr__(name: str) -> Any:
    """The API names, imported from :mod:`sonarproc.api` when first asked for."""
    if name in _API:
        from sonarproc import api

        return getattr(api, name)
    raise AttributeError(f"module 'sonarproc' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | _API)
