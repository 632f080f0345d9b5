"""Run several map-building methods on one log, and the numbers of the comparison.

:func:`compare` runs each method on a log already in memory (read once) with the same
run parameters; :func:`comparison_rows` and :func:`comparison_doc` are the single source
of every number the comparison files show (:mod:`sonarproc.report.comparison` writes
them).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sonarlog import SonarLog
from sonarproc.fit import FitFailure
from sonarproc.methods.base import MapMethod, MethodResult
from sonarproc.params import RunParams
from sonarproc.pipeline.result import RunResult
from sonarproc.report.jsonable import to_jsonable
from sonarproc.version import __version__

__all__ = [
    "COLUMNS",
    "compare",
    "comparison_doc",
    "comparison_rows",
    "fit_json",
    "fit_label",
    "measure_curve",
    "write_method_surfaces",
]

log = logging.getLogger(__name__)

#: Columns of ``compare.csv`` (and keys of each row of ``compare.json``'s ``methods``).
COLUMNS = (
    "method",
    "e",
    "f_c",
    "E1_m",
    "E2",
    "t_cpu_s",
    "N",
    "N_k",
    "points",
    "fit_ok",
    "fit_order",
    "fit",
    "precision_m",
    "completeness",
    "surfaces",
)

#: Files each method with surfaces writes into ``OUT/<method>/`` (:func:`write_method_surfaces`).
SURFACE_FILES = ("surfaces.csv", "surfaces.geojson")


def compare(log_: SonarLog, params: RunParams, methods: Sequence[MapMethod]) -> list[MethodResult]:
    """Run every method on ``log_`` with ``params`` (same grid, fit and metrics).

    Every method gets precision and completeness against a truth: its surfaces', or, when
    it fitted one curve, the curve's (:func:`measure_curve`), so the rows compare alike.
    """
    results = []
    for m in methods:
        log.info("%s: running %s", log_.path, m.name)
        r = m.run(log_, params)
        if r.run.surface_metrics is None and r.run.truth is not None and r.fit_ok:
            r.run.surface_metrics = measure_curve(r, log_, m.params_for(params))
        results.append(r)
    return results


def measure_curve(result: MethodResult, log_: SonarLog, params: RunParams) -> dict[str, Any]:
    """Precision and completeness of a run's one fitted curve, as if it were one surface.

    The curve is sampled over its domain every cell (as ``profile.csv``) and measured as
    the surfaces are (:func:`sonarproc.surfaces.surface_metrics`): against every truth
    polyline, completeness over the part of the truth the sonars saw (the readings are
    selected again as the run selected them).
    """
    from sonarproc.pipeline.selection import select_beams
    from sonarproc.surfaces import seen_truth, surface_metrics, truth_points

    run = result.run
    assert run.truth is not None and not isinstance(run.fit, FitFailure)
    truth = np.asarray(run.truth, dtype=np.float64)
    beams, _ = select_beams(log_, params)
    tp = beams.poses
    seen = seen_truth(
        np.concatenate(truth_points(truth)), tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading,
        beams.path, tx_half_beamwidth=tp.tx_half_beamwidth,
        rx_half_beamwidth=tp.rx_half_beamwidth,
    )  # fmt: skip
    curve = np.asarray(run.fit.sample(run.grid.cell), dtype=np.float64)
    return dict(surface_metrics([curve], truth, seen=seen).to_json())


def fit_label(run: RunResult) -> str:
    """A run's fit in a few words: ``order 9``, ``spline``, ``polar, order 9``, ``3 surfaces``.

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> fit_label(NS(surfaces=None, fit=NS(kind="spline", order=3)))
    'spline'
    >>> fit_label(NS(surfaces=NS(surfaces=[1, 2]), fit=NS(kind="poly", order=9)))
    '2 surfaces'
    """
    if run.surfaces is not None and run.surfaces.surfaces:
        return f"{len(run.surfaces.surfaces)} surfaces"
    fit = run.fit
    if isinstance(fit, FitFailure):
        return "FAILED"
    if fit.kind == "spline":
        return "spline"
    return f"order {fit.order}" if fit.kind == "poly" else f"{fit.kind}, order {fit.order}"


def fit_json(result: MethodResult) -> dict[str, Any]:
    """A method's fit for ``compare.json``'s ``fits``: the curve's, or its surfaces (a success).

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace as NS
    >>> from sonarproc.surfaces import SurfaceFit
    >>> s = SurfaceFit("line", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.002, 50, 80)
    >>> r = NS(surfaces=[s], run=NS(surface_metrics=None))
    >>> doc = fit_json(r)
    >>> doc["kind"], doc["ok"], doc["count"], doc["surfaces"][0]["model"]
    ('surfaces', True, 1, 'line')
    """
    if not result.surfaces:
        return dict(result.run.fit.to_json())
    return {
        "kind": "surfaces",
        "ok": True,
        "order": None,
        "count": len(result.surfaces),
        "surfaces": [s.to_json(k) for k, s in enumerate(result.surfaces)],
        "metrics": result.run.surface_metrics,
    }


def write_method_surfaces(result: MethodResult, out_dir: str | Path) -> list[Path]:
    """Write :data:`SURFACE_FILES` of a method with surfaces into ``OUT/<method>/``.

    The surfaces are numbered as in ``compare.json``'s ``fits`` (0 .. N-1); a method
    without surfaces (one curve, or none) writes nothing.
    """
    from sonarproc.surfaces import write_surfaces_csv, write_surfaces_geojson

    if not result.surfaces:
        return []
    folder = Path(out_dir) / result.method
    folder.mkdir(parents=True, exist_ok=True)
    return [
        write_surfaces_csv(result.surfaces, folder / SURFACE_FILES[0]),
        write_surfaces_geojson(result.surfaces, folder / SURFACE_FILES[1]),
    ]


def comparison_rows(results: Sequence[MethodResult]) -> list[dict[str, Any]]:
    """One row per method: the metrics, points kept, the fit's state, and the surfaces'.

    ``fit_ok`` is true for a surfaces fit; ``precision_m`` and ``completeness`` are the
    surfaces' against a truth of several surfaces (None without either), ``surfaces`` their
    count (0 for one curve).
    """
    rows = []
    for r in results:
        m = r.run.metrics
        surface_metrics = r.run.surface_metrics or {}
        rows.append(
            {
                "method": r.method,
                "e": m.e,
                "f_c": m.f_c,
                "E1_m": m.E1_m,
                "E2": m.E2,
                "t_cpu_s": r.run.t_cpu_s,
                "N": m.N,
                "N_k": m.N_k,
                "points": int(r.run.points_x.size),
                "fit_ok": r.fit_ok,
                "fit_order": r.run.fit.order,
                "fit": fit_label(r.run),
                # against a truth of several surfaces; None without surfaces or truth
                "precision_m": surface_metrics.get("precision_m"),
                "completeness": surface_metrics.get("completeness"),
                "surfaces": len(r.surfaces),
            }
        )
    return [dict(to_jsonable(row)) for row in rows]


def comparison_doc(
    source: str, params: RunParams, results: Sequence[MethodResult]
) -> dict[str, Any]:
    """The content of ``compare.json``."""
    g = results[0].run.grid if results else None
    doc = {
        "format": "sonarproc-compare",
        "version": 1,
        "software": {"sonarmorph": __version__},
        "source": source,
        "parameters": params.to_json(),
        "grid": None
        if g is None
        else {"x0": g.x0, "y0": g.y0, "cell": g.cell, "nx": g.nx, "ny": g.ny},
        "truth": bool(results and results[0].run.truth is not None),
        "methods": comparison_rows(results),
        "options": {r.method: r.options for r in results},
        "fits": {r.method: fit_json(r) for r in results},
        "counts": {r.method: r.run.counts for r in results},
    }
    return dict(to_jsonable(doc))
