"""The seam every map-building method plugs into: :class:`MapMethod`.

A method turns the selected readings of a log (with their transducer poses and path
lengths, :class:`Beams`) into a map on a :class:`~sonarproc.grid.Grid`
(:class:`MethodMap`: the binary map whose cells are fitted, an evidence count per cell and,
for probabilistic methods, p(occupied)). Everything around that one step is shared and
lives here (template method, :meth:`MapMethod.run`): reading selection and the grid are
``sonarproc run``'s (:func:`sonarproc.pipeline.select_readings`, the arcs' bounding box),
and the fit and the metrics (e, f_c, E1, E2, t_cpu) are computed exactly as
:func:`sonarproc.pipeline.process` computes them, so every method is judged the same way.
Every method uses the same grid (the arcs' bounding box, or ``--bbox``), so their columns,
and hence N in f_c and the columns E1 averages over, are identical.

``t_cpu_s`` is the process CPU time from selecting the readings of the log in memory to
the metrics (the log is read once and shared by every method of a comparison).
"""

from __future__ import annotations

import logging
import time
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.errors import ParameterError
from sonarproc.fit import FitFailure
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import MethodMap, Stage, map_log
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams
from sonarproc.surfaces import SurfaceFit

__all__ = ["Beams", "MapMethod", "MethodMap", "MethodResult", "OptionValue"]

log = logging.getLogger(__name__)

OptionValue = float | int | str
BoolMap = npt.NDArray[np.bool_]


@dataclass
class MethodResult:
    """One method's run: its name and options, the run record, and its map."""

    method: str
    options: dict[str, OptionValue]
    run: RunResult
    probability: npt.NDArray[np.float64] | None = None

    @property
    def surfaces(self) -> list[SurfaceFit]:
        """The surfaces fitted one by one (``fit = "auto"`` on a scene of several), or []."""
        found = self.run.surfaces
        return list(found.surfaces) if found is not None else []

    @property
    def fit_ok(self) -> bool:
        """Whether the run has a fit: its surfaces, or one curve (a surfaces fit succeeds)."""
        return bool(self.surfaces) or not isinstance(self.run.fit, FitFailure)


class MapMethod(ABC):
    """Base class of the map-building methods (one registry entry each).

    Subclasses set :attr:`name`, :attr:`summary` and :attr:`defaults` (every option with
    its default value; the type of the default is the option's type) and implement
    :meth:`build`. :meth:`run` is the template: select, grid, build, fit, metrics.

    Parameters
    ----------
    **options
        Overrides of :attr:`defaults`; unknown names or values of the wrong type raise
        ``ValueError``.
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    defaults: ClassVar[Mapping[str, OptionValue]] = {}

    def __init__(self, **options: OptionValue) -> None:
        opts = dict(self.defaults)
        for key, value in options.items():
            if key not in opts:
                known = ", ".join(sorted(opts)) or "none"
                raise ParameterError(self.name, f"has no option {key!r} (options: {known})")
            opts[key] = _coerce(self.name, key, value, opts[key])
        self.options: dict[str, OptionValue] = opts
        self.validate()

    def validate(self) -> None:  # noqa: B027 - optional hook
        """Check :attr:`options`; raise ``ValueError`` naming the bad one."""

    def params_for(self, params: RunParams) -> RunParams:
        """The run parameters this method uses (default: unchanged)."""
        return params

    @abstractmethod
    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        """Build the method's map of ``beams`` on ``grid``."""

    def run(self, log_: SonarLog, params: RunParams) -> MethodResult:
        """Map the log with this method, then fit and measure as ``sonarproc run`` does.

        Raises
        ------
        SonarprocError
            Unusable log or parameters (the same cases as ``sonarproc run``).
        """
        cpu0 = time.process_time()
        params = self.params_for(params)

        def build(beams: Beams, grid: Grid, p: RunParams, stage: Stage | None = None) -> MethodMap:
            if stage is not None:
                stage("map")
            return self.build(beams, grid, p)

        empty = f"{log_.path}: the method left nothing on the map"
        result, mmap = map_log(log_, params, build, cpu_start=cpu0, empty_message=empty)
        return MethodResult(self.name, dict(self.options), result, mmap.probability)


def _coerce(method: str, key: str, value: OptionValue, default: OptionValue) -> OptionValue:
    try:
        if isinstance(default, bool):
            raise TypeError
        if isinstance(default, int):
            return int(value)
        if isinstance(default, float):
            return float(value)
    except (TypeError, ValueError):
        raise ParameterError(
            method, f"option {key} must be a {type(default).__name__}, got {value!r}"
        ) from None
    return str(value)
