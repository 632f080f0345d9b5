"""Run several map-building methods on one log, and the numbers of the comparison.

:func:`compare` runs each method on a log already in memory (read once) with the same
run parameters; :func:`comparison_rows` and :func:`comparison_doc` are the single source
of every number the comparison files show (:mod:`sonarproc.report.comparison` writes
them).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

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
    "fit_label",
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
)


def compare(log_: SonarLog, params: RunParams, methods: Sequence[MapMethod]) -> list[MethodResult]:
    """Run every method on ``log_`` with ``params`` (same grid, fit and metrics)."""
    results = []
    for m in methods:
        log.info("%s: running %s", log_.path, m.name)
        results.append(m.run(log_, params))
    return results


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


def comparison_rows(results: Sequence[MethodResult]) -> list[dict[str, Any]]:
    """One row per method: the metrics, points kept and the fit's state."""
    rows = []
    for r in results:
        m = r.run.metrics
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
                "fit_ok": not isinstance(r.run.fit, FitFailure),
                "fit_order": r.run.fit.order,
                "fit": fit_label(r.run),
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
        "fits": {r.method: r.run.fit.to_json() for r in results},
        "counts": {r.method: r.run.counts for r in results},
    }
    return dict(to_jsonable(doc))
