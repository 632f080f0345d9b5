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
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog, TransducerPoses
from sonarproc.arcs import arc_bounds
from sonarproc.evaluation import fit_and_measure, make_grid, map_counts
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, select_readings

__all__ = ["Beams", "MapMethod", "MethodMap", "MethodResult", "OptionValue", "shared_grid"]

log = logging.getLogger(__name__)

OptionValue = float | int | str
BoolMap = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class Beams:
    """The readings a method maps, with their geometry (one row per reading)."""

    readings: np.ndarray
    poses: TransducerPoses
    path: npt.NDArray[np.float64]

    @property
    def arcs_args(self) -> tuple[Any, ...]:
        """Positional arguments of :func:`sonarproc.arcs.rasterize_arcs`."""
        tp = self.poses
        return (tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, self.path)

    @property
    def beam_kwargs(self) -> dict[str, Any]:
        """Keyword half-beamwidths of :func:`sonarproc.arcs.rasterize_arcs`."""
        tp = self.poses
        return {
            "tx_half_beamwidth": tp.tx_half_beamwidth,
            "rx_half_beamwidth": tp.rx_half_beamwidth,
        }


@dataclass
class MethodMap:
    """What a method builds on the grid.

    Attributes
    ----------
    processed : ndarray of bool, grid.shape
        The cells the curve is fitted to (the method's "processed map").
    evidence : ndarray of unsigned int, grid.shape
        Per-cell evidence shown in the figures (arc counts, hits, occupied-band counts);
        its nonzero columns are the f_c denominator when there is no truth profile.
    probability : ndarray of float, grid.shape, optional
        p(occupied) of a probabilistic method (0.5 = unknown); the ROS map uses it.
    """

    processed: BoolMap
    evidence: npt.NDArray[np.unsignedinteger[Any]]
    probability: npt.NDArray[np.float64] | None = None


@dataclass
class MethodResult:
    """One method's run: its name and options, the run record, and its map."""

    method: str
    options: dict[str, OptionValue]
    run: RunResult
    probability: npt.NDArray[np.float64] | None = None


def shared_grid(log_: SonarLog, params: RunParams, beams: Beams) -> Grid:
    """The grid ``sonarproc run`` would use: ``params.bbox`` or the arcs' bounding box."""
    source = str(log_.path)
    try:
        bounds = arc_bounds(*beams.arcs_args, **beams.beam_kwargs)
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from err
    return make_grid(params, bounds, source)


def select_beams(log_: SonarLog, params: RunParams) -> tuple[Beams, dict[str, int]]:
    """The readings ``sonarproc run`` keeps, their transducer poses and path lengths."""
    readings, counts = select_readings(log_, drop_crosstalk=params.drop_crosstalk)
    return (
        Beams(readings, log_.transducer_poses(readings), log_.path_lengths(readings)),
        counts,
    )


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
                raise ValueError(f"{self.name}: unknown option {key!r} (options: {known})")
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
        ValueError
            Unusable log or parameters (the same cases as ``sonarproc run``).
        """
        cpu0 = time.process_time()
        params = self.params_for(params)
        timings: dict[str, float] = {}
        t = time.perf_counter()
        beams, counts = select_beams(log_, params)
        grid = shared_grid(log_, params, beams)
        timings["select"] = time.perf_counter() - t
        t = time.perf_counter()
        mmap = self.build(beams, grid, params)
        timings["map"] = time.perf_counter() - t
        t = time.perf_counter()
        result = evaluate(log_, params, grid, beams, counts, mmap, cpu0)
        timings["fit_metrics"] = time.perf_counter() - t
        result.timings_s = timings
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
        raise ValueError(
            f"{method}: option {key} must be a {type(default).__name__}, got {value!r}"
        ) from None
    return str(value)


def evaluate(
    log_: SonarLog,
    params: RunParams,
    grid: Grid,
    beams: Beams,
    counts: dict[str, int],
    mmap: MethodMap,
    cpu0: float,
) -> RunResult:
    """Fit and measure a method's map the way :func:`sonarproc.pipeline.process` does."""
    source = str(log_.path)
    counts = {
        **counts,
        **map_counts(mmap.evidence, empty=f"{source}: the method left nothing on the map"),
    }
    truth = None if log_.truth is None else np.asarray(log_.truth, dtype=np.float64)
    readings = beams.readings
    ev = fit_and_measure(
        params,
        grid,
        mmap.processed,
        mmap.evidence,
        truth=truth,
        robot_xy=np.column_stack((readings["x"], readings["y"])).astype(np.float64),
    )
    t_cpu = time.process_time() - cpu0
    return RunResult.of(
        ev,
        source=source,
        params=params,
        grid=grid,
        counts_map=mmap.evidence,
        processed=mmap.processed,
        truth=truth,
        counts=counts,
        t_cpu_s=t_cpu,
    )
