"""Write a run's report directory: report.json, profile.csv, three figures and report.html.

Each figure is written as a 150 dpi PNG (embedded in ``report.html``) and/or a vector SVG
beside it, for print, as ``figures`` asks (``--figures``); with none, no figure is drawn
and matplotlib is not imported.

:func:`report_dict` is the single source of every number the files show; the writers only
format it. The file set is documented in docs/formats.md.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc import __version__
from sonarproc.fit import FitFailure
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.run import METHOD
from sonarproc.report.jsonable import to_jsonable

__all__ = [
    "DEFAULT_FIGURES",
    "REPORT_FILES",
    "default_out_dir",
    "profile_points",
    "report_dict",
    "report_files",
    "write_profile_csv",
    "write_report",
]

log = logging.getLogger(__name__)

REPORT_FILES = (
    "report.json",
    "profile.csv",
    "arcmap.png",
    "arcmap.svg",
    "processed.png",
    "processed.svg",
    "fit.png",
    "fit.svg",
    "report.html",
)
#: The figure formats written when none are named (``--figures png,svg``).
DEFAULT_FIGURES = ("png", "svg")


def report_files(figures: Sequence[str] = DEFAULT_FIGURES) -> tuple[str, ...]:
    """The files of :data:`REPORT_FILES` a report with figures in ``figures`` has.

    >>> report_files(())
    ('report.json', 'profile.csv', 'report.html')
    """
    return tuple(
        n for n in REPORT_FILES if not n.endswith((".png", ".svg")) or n.rsplit(".")[1] in figures
    )


def default_out_dir(log_path: str | Path) -> Path:
    """``LOG_report/`` beside the log (``scan.h5`` -> ``scan_report/``)."""
    p = Path(log_path)
    return p.with_name(f"{p.stem}_report")


def report_dict(result: RunResult, *, auto: dict[str, Any] | None = None) -> dict[str, Any]:
    """The content of ``report.json``.

    Keys: ``format``, ``version``, ``software``, ``source``, ``method``, ``parameters``,
    ``grid``, ``counts``, ``log_state`` (``closed``, ``crashed``, ``cut``), ``intact_rows``,
    ``dropped_rows``, ``fit``, ``metrics`` (``e``, ``f_c``, ``t_cpu_s``, ``N``, ``N_k``
    and, when the log has a truth profile, ``E1_m``, ``E2``, ``sigma_y_m``), ``truth``,
    ``timings_s``; with ``auto`` (``run --auto``'s record), ``auto``.
    """
    g = result.grid
    m = result.metrics.to_json()
    metrics: dict[str, Any] = {
        "e": m["e"],
        "f_c": m["f_c"],
        "t_cpu_s": result.t_cpu_s,
        "N": m["N"],
        "N_k": m["N_k"],
    }
    polar = result.params.fit == "polar"
    if result.truth is not None and (polar or not np.isnan(result.truth).any()):
        metrics.update(E1_m=m["E1_m"], E2=m["E2"], sigma_y_m=m["sigma_y_m"])
    if result.surface_metrics is not None:
        metrics.update(result.surface_metrics)
    fit = result.fit.to_json()
    if result.centre is not None:
        fit.setdefault("centre", list(result.centre))
    doc = {
        "format": "sonarproc-report",
        "version": 1,
        "software": {"sonarmorph": __version__},
        "source": result.source,
        "method": METHOD,
        "parameters": result.params.to_json(),
        "grid": {
            "x0": g.x0,
            "y0": g.y0,
            "cell": g.cell,
            "nx": g.nx,
            "ny": g.ny,
            "extent": list(g.centre_extent),
        },
        "counts": dict(result.counts),
        "log_state": result.log_state,
        "intact_rows": int(result.counts.get("readings_total", 0)),
        "dropped_rows": int(result.counts.get("dropped_torn_rows", 0)),
        "fit": fit,
        "metrics": metrics,
        "truth": result.truth is not None,
        "timings_s": {k: round(v, 6) for k, v in result.timings_s.items()},
    }
    if result.auto is not None:
        doc["fit_choice"] = result.auto
    if auto is not None:
        doc["auto"] = auto
    if result.surfaces is not None:
        doc["surfaces"] = result.surfaces.to_json()
        if result.surfaces.reason:
            doc["surfaces_reason"] = result.surfaces.reason
    return dict(to_jsonable(doc))


def profile_points(result: RunResult) -> npt.NDArray[np.float64]:
    """The fitted profile sampled every cell: sorted by x, or a closed polyline (polar)."""
    if isinstance(result.fit, FitFailure):
        return np.zeros((0, 2))
    return result.fit.sample(result.grid.cell)


def write_profile_csv(path: Path, points: npt.NDArray[np.float64]) -> None:
    """Write ``x,y`` rows (m) with a header; an empty body when the fit failed."""
    with path.open("w", encoding="utf-8", newline="") as fh:
        fh.write("x,y\n")
        if points.size:
            np.savetxt(fh, points, delimiter=",", fmt="%.6f")


def write_report(
    result: RunResult,
    out_dir: str | Path,
    *,
    auto: dict[str, Any] | None = None,
    figures: Sequence[str] = DEFAULT_FIGURES,
) -> dict[str, Any]:
    """Write the files of :func:`report_files` into ``out_dir``; return the report dict.

    ``auto``: the ``--auto`` record (report.json's ``auto``, a section of report.html);
    ``figures``: the figure formats (``png``, ``svg``; empty: no figures).
    """
    from sonarproc.report import plots
    from sonarproc.report.html import render_html

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    doc = report_dict(result, auto=auto)
    (out / "report.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    write_profile_csv(out / "profile.csv", profile_points(result))
    if result.surfaces is not None:
        from sonarproc.surfaces import write_surfaces_csv, write_surfaces_geojson

        write_surfaces_csv(result.surfaces.surfaces, out / "surfaces.csv")
        write_surfaces_geojson(result.surfaces.surfaces, out / "surfaces.geojson")
    drawn = plots.render_figures(result, figures, auto=auto)
    for name, data in drawn.items():
        (out / name).write_bytes(data)
    (out / "report.html").write_text(render_html(doc, drawn), encoding="utf-8")
    log.info("wrote report to %s", out)
    return doc
