"""The truth-free quality of a run's map, judged from its own readings.

Two figures, both with the first-echo prediction of ``--auto``
(:mod:`sonarproc.quality.predict`):

- the *held-out range residual*: one firing in :data:`HELDOUT_FOLDS` (every reading of a
  firing together, the folds of ``--auto``, :func:`sonarproc.auto.holdout.firing_folds`)
  is left out, the map is built and fitted again from the other firings exactly as the
  run did (same builder, same parameters, same fit), and each left-out reading's range
  ``|measured - predicted| / 2`` is predicted from that map: its median and 90th
  percentile. One fold refitted once, not all ``k`` of a k-fold: the figure costs one
  more fit, not ``k``, and is still honestly held out (no left-out reading touched the
  map that predicts it). At most :data:`MAX_HELDOUT` left-out readings are predicted
  (a fixed-seed subsample).

  A held-out reading whose beams no surface of the held-out map crosses (or whose
  predicted echo lies beyond the sensor's largest range) has no predicted range: it has
  no residual, and counts against ``heldout_predicted_fraction`` (and, in sample,
  against the explained fraction) instead. Counting it as the largest range would make
  the residual a figure of the sensor's range setting and of how a driver reports
  silence, not of the map. A reading the map does predict keeps its whole residual,
  whichever way it errs: one that ends short of the predicted echo heard a reflector
  the map lacks (the map says the beam is free up to the surface behind it), one that
  reaches beyond it saw through a surface the map has. On a sparse map the first kind
  can reach metres (from the unmapped reflector to the wall behind it): that is the
  map's error, and the figure shows it.
- the *fraction of readings explained*: of the readings the run mapped (at most
  :data:`MAX_EXPLAINED` of them, a fixed-seed subsample), those whose range the run's
  own map predicts within :data:`TOLERANCE` (5 cm); a reading whose beams no surface
  crosses is not explained. Per surface too: each reading belongs to the surface that
  gives its predicted echo.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.errors import SonarprocError
from sonarproc.fit import FitFailure
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import MapBuilder, MethodMap
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams
from sonarproc.quality.predict import MapCurves, curves_of, map_curves, predict_paths

__all__ = [
    "HELDOUT_FOLDS",
    "MAX_EXPLAINED",
    "MAX_HELDOUT",
    "TOLERANCE",
    "HeldOut",
    "HeldOutResidual",
    "Quality",
    "explained",
    "held_out",
    "heldout_curves",
    "heldout_residual",
    "judged_rows",
    "measure_quality",
    "training_map",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: A reading is explained when its range is predicted within this much (m). A Polaroid
#: ranger resolves about 1 cm and errs by about 1 % of the range (3 cm at 3 m, from the
#: speed of sound's dependence on temperature and the echo's rise time); 5 cm is above
#: that at the ranges a map is made from, and well below the distance between two
#: surfaces a map keeps apart (a wall and the door set in it, a wall seen twice through
#: drifting odometry).
TOLERANCE = 0.05
#: One firing in this many is held out of the refit (10 %: the refitted map is nearly the
#: run's own, and its left-out readings are still a few hundred on a short log).
HELDOUT_FOLDS = 10
#: Most held-out readings predicted (a fixed-seed subsample): the median and 90th
#: percentile of 500 residuals are known to within a few per cent of their spread
#: (the 90th percentile's rank to within +-1.3 %).
MAX_HELDOUT = 500
#: Most mapped readings the explained fraction is judged on (a fixed-seed subsample):
#: its standard error is then at most 1.6 % (a fraction of 0.5 from 1000 readings),
#: finer than any decision taken on it.
MAX_EXPLAINED = 1000
#: Seed of the held-out fold and of the subsamples (the figures repeat run to run).
SEED = 0


@dataclass(frozen=True, eq=False)
class Quality:
    """Truth-free figures of a run's map (``report.json``'s ``quality``).

    Attributes
    ----------
    explained_fraction : float or None
        Fraction of the judged readings whose range the map predicts within
        :data:`TOLERANCE`; None with no reading judged.
    explained_readings : int
        Readings judged (the run's mapped readings, subsampled to :data:`MAX_EXPLAINED`).
    heldout_median_m, heldout_p90_m : float or None
        Median and 90th percentile of the held-out readings' range residuals (m), over
        those the held-out map predicts; None when there are none (see ``reason``).
    heldout_readings : int
        Held-out readings predicted (subsampled to :data:`MAX_HELDOUT`).
    heldout_predicted_fraction : float or None
        Fraction of them whose beams the held-out map crosses.
    surfaces : list of dict
        Per surface: ``surface`` (id), ``readings`` (judged readings it gives the echo
        of) and ``explained_fraction`` (None without readings).
    reason : str or None
        Why a figure is missing (a failed fit, a held-out map left empty).
    """

    explained_fraction: float | None
    explained_readings: int
    heldout_median_m: float | None
    heldout_p90_m: float | None
    heldout_readings: int
    heldout_predicted_fraction: float | None
    surfaces: list[dict[str, Any]] = field(default_factory=list)
    reason: str | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready figures (the contract in docs/formats.md)."""
        return {
            "tolerance_m": TOLERANCE,
            "explained_fraction": self.explained_fraction,
            "explained_readings": self.explained_readings,
            "heldout_residual_median_m": self.heldout_median_m,
            "heldout_residual_p90_m": self.heldout_p90_m,
            "heldout_readings": self.heldout_readings,
            "heldout_predicted_fraction": self.heldout_predicted_fraction,
            "heldout_scheme": (
                f"one firing in {HELDOUT_FOLDS} held out (seed {SEED}), the map refitted "
                f"once from the others; at most {MAX_HELDOUT} held-out readings predicted"
            ),
            "surfaces": [dict(s) for s in self.surfaces],
            "reason": self.reason,
        }


def _subsample(rows: IntArray, most: int, seed: int) -> IntArray:
    if rows.size <= most:
        return rows
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(rows, size=most, replace=False))


def explained(
    curves: MapCurves, beams: Beams, rows: IntArray
) -> tuple[float | None, list[dict[str, Any]]]:
    """Fraction of readings ``rows`` the curves explain within :data:`TOLERANCE`, overall
    and per surface.

    Examples
    --------
    >>> from sonarproc.methods.testing import flat_wall_beams
    >>> from sonarproc.quality.predict import resample
    >>> beams, _ = flat_wall_beams(10)
    >>> wall = resample(np.array([[-1.0, 1.0], [3.0, 1.0]]), 0.01)
    >>> explained(MapCurves([wall], [0], single=True), beams, np.arange(beams.path.size))
    (1.0, [{'surface': 0, 'readings': 7, 'explained_fraction': 1.0}])
    """
    if rows.size == 0:
        return None, []
    path, surface = predict_paths(curves, beams, rows)
    residual = 0.5 * np.abs(beams.path[rows] - path)
    ok = np.isfinite(residual) & (residual <= TOLERANCE)
    per = []
    for sid in curves.surface:
        mine = surface == sid
        n = int(mine.sum())
        per.append({
            "surface": int(sid),
            "readings": n,
            "explained_fraction": float(ok[mine].mean()) if n else None,
        })  # fmt: skip
    return float(ok.mean()), per


def training_map(
    build: MapBuilder,
    beams: Beams,
    train: BoolArray,
    grid: Grid,
    params: RunParams,
    full: MethodMap,
) -> tuple[Beams, MethodMap]:
    """The readings ``train`` of ``beams`` and the map ``build`` makes of them on ``grid``.

    The paper's arc map counts distinct arcs per cell, so the training readings' count
    map is the run's less the held-out readings' arcs: only those are drawn again (a
    tenth of the rasterising), then the ``ops`` chain runs on the difference. Any other
    builder builds from the training readings.
    """
    from sonarproc.auto.holdout import subset_beams
    from sonarproc.pipeline.arcmap import build_arc_map, count_map

    train_beams = subset_beams(beams, train)
    counts = None
    if build is build_arc_map:
        held_arcs = subset_beams(beams, ~train).arcs
        counts = full.evidence - count_map(held_arcs, grid, params).astype(full.evidence.dtype)
    return train_beams, _training_map(build, train_beams, counts, grid, params)


def _training_map(
    build: MapBuilder,
    train_beams: Beams,
    train_counts: npt.NDArray[Any] | None,
    grid: Grid,
    params: RunParams,
) -> MethodMap:
    """The held-out map: the ``ops`` chain on the training count map (the paper's arc
    map), or ``build`` of the training readings."""
    if train_counts is None:
        return build(train_beams, grid, params, None)
    from sonarproc.morphology import apply_chain, parse_chain

    return MethodMap(apply_chain(train_counts, parse_chain(params.ops)), train_counts)


@dataclass(frozen=True, eq=False)
class HeldOut:
    """What a run's quality takes from its readings and count map alone, before its
    ``ops`` and fit: the same for every run on them (a sweep computes it once per map).

    Attributes
    ----------
    judged : ndarray of int
        The readings the explained fraction is judged on.
    held : ndarray of bool or None
        The held-out firings' readings; None when there are fewer than
        :data:`HELDOUT_FOLDS` firings (nothing to hold out).
    held_rows : ndarray of int
        The held-out readings predicted (empty with ``held`` None).
    train_beams : Beams or None
        The other readings, the held-out map is built from.
    train_counts : ndarray of unsigned int or None
        Their arc count map (the run's less the held-out arcs), for the paper's arc map
        (:func:`training_map`); None for any other builder.
    """

    judged: IntArray
    held: BoolArray | None
    held_rows: IntArray
    train_beams: Beams | None
    train_counts: npt.NDArray[np.unsignedinteger[Any]] | None


def held_out(
    beams: Beams, grid: Grid, params: RunParams, counts: npt.NDArray[Any] | None = None
) -> HeldOut:
    """The subsamples, the held-out fold and the training readings of ``beams``.

    Parameters
    ----------
    beams : Beams
        The readings the run mapped.
    grid : Grid
        The run's grid.
    params : RunParams
        The run's parameters (``arc_step``: how the held-out arcs are drawn).
    counts : ndarray, optional
        The run's arc count map, when the run builds the paper's arc map: the training
        count map is then made from it (:func:`training_map`).
    """
    from sonarproc.auto.holdout import firing_folds, subset_beams

    judged = judged_rows(beams)
    held = firing_folds(beams.readings, HELDOUT_FOLDS, seed=SEED) == 0
    if held.all() or not held.any():
        return HeldOut(judged, None, np.zeros(0, dtype=np.intp), None, None)
    held_rows = _subsample(np.flatnonzero(held).astype(np.intp), MAX_HELDOUT, SEED + 1)
    train_beams = subset_beams(beams, ~held)
    train_counts = None
    if counts is not None:
        from sonarproc.pipeline.arcmap import count_map

        held_arcs = subset_beams(beams, held).arcs
        # the held-out arcs' map, a fresh array, becomes the training map in place (no
        # third map of the grid's size)
        train_counts = count_map(held_arcs, grid, params).astype(counts.dtype, copy=False)
        np.subtract(counts, train_counts, out=train_counts)
        train_counts.flags.writeable = False  # shared by every run on this map
    return HeldOut(judged, held, held_rows, train_beams, train_counts)


def heldout_curves(params: RunParams, grid: Grid, mmap: MethodMap, beams: Beams) -> MapCurves:
    """The curves a run's fit makes of the map ``mmap`` of ``beams``: what
    :func:`sonarproc.pipeline.mapping.evaluate_map` fits (``fit = "auto"``: the surfaces
    :func:`~sonarproc.pipeline.surfacefit.choose_fit` finds, or the polynomial where it
    finds one curve y = f(x); else the run's own fit), without its metrics."""
    from sonarproc.pipeline.evaluation import fit_and_measure

    fit_params = params
    if params.fit == "auto":
        from sonarproc.pipeline.surfacefit import choose_fit

        # its test of one curve reads the map's column spans off the map itself: the kept
        # cells one by one (millions on a long log's map) are needed for a curve's fit only
        auto = choose_fit(mmap.processed, mmap.evidence, grid, beams)
        if auto.surfaces is not None:
            return curves_of(auto.surfaces, FitFailure("surfaces", ""), grid.cell)
        fit_params = replace(params, fit="poly")
    ix, iy = np.nonzero(mmap.processed.T)
    if ix.size == 0:
        return MapCurves([], [], single=True)
    ev = fit_and_measure(fit_params, grid, mmap.processed, mmap.evidence, truth=None,
                         robot_xy=beams.robot_xy, cells=(ix, iy))  # fmt: skip
    return curves_of(None, ev.fit, grid.cell)


@dataclass(frozen=True)
class HeldOutResidual:
    """The held-out range residual of a run's map (:func:`heldout_residual`).

    Attributes
    ----------
    readings : int
        Held-out readings predicted.
    median_m, p90_m : float or None
        Median and 90th percentile of their range residuals (m).
    predicted_fraction : float or None
        Fraction of them whose beams the held-out map crosses.
    reasons : tuple of str
        Why a figure is missing.
    """

    readings: int
    median_m: float | None
    p90_m: float | None
    predicted_fraction: float | None
    reasons: tuple[str, ...]


def judged_rows(beams: Beams) -> IntArray:
    """The readings of ``beams`` the explained fraction is judged on (:attr:`HeldOut.judged`)."""
    return _subsample(np.arange(int(beams.path.size), dtype=np.intp), MAX_EXPLAINED, SEED)


def heldout_residual(
    held: HeldOut, build: MapBuilder, beams: Beams, grid: Grid, params: RunParams
) -> HeldOutResidual:
    """The held-out readings of ``held`` predicted from the map ``build`` makes of the
    others and the run's fit of it (module notes): a figure of the readings, count map
    and parameters alone, never of the run's own fit (so it may be computed meanwhile,
    :mod:`sonarproc.quality.ahead`)."""
    if held.held is None or held.train_beams is None:
        reason = f"fewer than {HELDOUT_FOLDS} firings: nothing to hold out"
        return HeldOutResidual(0, None, None, None, (reason,))
    reasons = []
    try:
        train_map = _training_map(build, held.train_beams, held.train_counts, grid, params)
        train_curves = heldout_curves(params, grid, train_map, held.train_beams)
    except SonarprocError as err:  # a method that leaves nothing on the held-out map
        reasons.append(f"the held-out map: {err}")
        train_curves = MapCurves([], [], single=True)
    path, _ = predict_paths(train_curves, beams, held.held_rows)
    residual = 0.5 * np.abs(beams.path[held.held_rows] - path)
    hit = np.isfinite(residual)
    median = p90 = None
    if hit.any():
        median = float(np.median(residual[hit]))
        p90 = float(np.percentile(residual[hit], 90.0))
    else:
        reasons.append("the held-out map predicts none of the held-out readings")
    n = int(held.held_rows.size)
    return HeldOutResidual(n, median, p90, float(hit.mean()), tuple(reasons))


def measure_quality(
    log_: SonarLog,
    params: RunParams,
    build: MapBuilder,
    beams: Beams,
    grid: Grid,
    full: MethodMap,
    result: RunResult,
    *,
    held: HeldOut | None = None,
    residual: HeldOutResidual | Callable[[], HeldOutResidual] | None = None,
) -> Quality:
    """The truth-free quality of ``result``, the run of ``build`` on ``beams`` (module notes).

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The run's log (its truth, if any, is not used).
    params : RunParams
        The run's parameters: the held-out map is built and fitted with them.
    build : MapBuilder
        The run's map builder.
    beams : Beams
        The readings the run mapped.
    grid : Grid
        The run's grid.
    full : MethodMap
        The run's map of all ``beams``.
    result : RunResult
        The run's record (its surfaces or profile are the map judged).
    held : HeldOut, optional
        :func:`held_out` of ``beams`` (with ``full.evidence`` for the paper's arc map),
        when the caller keeps it for several runs on the same readings and count map.
    residual : HeldOutResidual or callable, optional
        :func:`heldout_residual` of these readings and map, when the caller computes it
        (meanwhile, in a child: :mod:`sonarproc.quality.ahead`); a callable is called
        after the explained fraction is measured, to give a child that time too.
    """
    from sonarproc.pipeline.arcmap import build_arc_map

    if residual is None and held is None:
        held = held_out(beams, grid, params, full.evidence if build is build_arc_map else None)
    judged = held.judged if held is not None else judged_rows(beams)
    curves = map_curves(result)
    fraction, per = explained(curves, beams, judged)
    reasons = [] if not curves.empty else ["the map has no fitted surface to predict from"]
    if residual is None:
        assert held is not None  # made above
        residual = heldout_residual(held, build, beams, grid, params)
    elif callable(residual):
        residual = residual()
    reasons.extend(residual.reasons)
    return Quality(
        fraction, int(judged.size), residual.median_m, residual.p90_m, residual.readings,
        residual.predicted_fraction, per, "; ".join(reasons) or None,
    )  # fmt: skip
