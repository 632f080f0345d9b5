"""Write a run's report directory: report.json, profile.csv, three figures and report.html.

Each figure is written as a 150 dpi PNG (embedded in ``report.html``; the default) and/or
a vector SVG beside it, for print, as ``figures`` asks (``--figures``); with none, no
figure is drawn and matplotlib is not imported.

:func:`report_dict` is the single source of every number the files show; the writers only
format it. The file set is documented in docs/formats.md.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.fit import FitFailure
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.run import METHOD
from sonarproc.report.jsonable import to_jsonable
from sonarproc.version import __version__

if TYPE_CHECKING:
    from sonarproc.report.ahead import AheadFigures

__all__ = [
    "DEFAULT_FIGURES",
    "REPORT_FILES",
    "default_out_dir",
    "profile_points",
    "read_report",
    "report_dict",
    "report_files",
    "upgrade_report",
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
#: The figure formats written when none are named (``--figures png``): the PNGs are what
#: report.html shows; an SVG of a dense map costs as much again to draw and is for print,
#: one option away (``--figures png,svg``).
DEFAULT_FIGURES = ("png",)


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
    ``timings_s``, ``quality`` (the truth-free figures of :mod:`sonarproc.quality`, None
    when not measured); ``alignment`` when the poses were aligned (or alignment was
    tried); with ``auto`` (``run --auto``'s record), ``auto``. A surfaces fit
    (``fit = "auto"`` on a room) has ``fit`` = ``{"kind": "surfaces", "ok": true,
    "surfaces": N, ...}``, a ``surfaces`` list (``kind``, ``model``, ``length_m``,
    ``rms_m``, ``support`` each) and, on a log with a truth, ``precision_m`` and
    ``completeness`` in ``metrics`` (E1 and E2 are not defined for several surfaces).
    """
    g = result.grid
    metrics = result.metrics_json()
    fit = result.fit_json()
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
    doc["quality"] = result.quality.to_json() if result.quality is not None else None
    if result.alignment is not None:
        doc["alignment"] = result.alignment.to_json()
    if result.auto is not None:
        doc["fit_choice"] = result.auto
    if auto is not None:
        doc["auto"] = auto
    surfaces = result.surfaces_json()
    if result.surfaces is not None and surfaces is not None:
        doc["surfaces"] = surfaces
        if result.surfaces.reason:
            doc["surfaces_reason"] = result.surfaces.reason
    return dict(to_jsonable(doc))


def upgrade_report(doc: dict[str, Any]) -> dict[str, Any]:
    """A ``report.json`` of any earlier version in today's shape (Contract 2, v3).

    Earlier runs recorded a surfaces fit as a failure (``"ok": false``, "N surface(s)
    fitted one by one") and could put ``precision_m`` and ``completeness`` at the top
    level, null without a truth. Here the fit becomes the success it was (``ok``,
    ``surfaces``), non-null measures move into ``metrics``, and every fitted surface
    gets its ``kind``. A current report comes back unchanged.

    >>> old = {"fit": {"kind": "surfaces", "ok": False, "reason": "2 surface(s) fitted"},
    ...        "metrics": {"e": 0.5}, "precision_m": None, "completeness": None,
    ...        "surfaces": [{"surface": 0, "ok": True, "model": "line"},
    ...                     {"surface": 1, "ok": True, "model": "arc"}]}
    >>> new = upgrade_report(old)
    >>> new["fit"]["ok"], new["fit"]["surfaces"], new["fit"]["kinds"]
    (True, 2, {'cylinder': 1, 'plane': 1})
    >>> new["metrics"], "precision_m" in new, new["surfaces"][1]["kind"]
    ({'e': 0.5}, False, 'cylinder')
    """
    from sonarproc.pipeline.surfacefit import surface_kind

    out = dict(doc)
    out.setdefault("quality", None)  # reports before v3 measured no quality
    metrics = dict(out.get("metrics") or {})
    for key in ("precision_m", "completeness"):
        if key in out:
            value = out.pop(key)
            if value is not None:
                metrics.setdefault(key, value)
    out["metrics"] = metrics
    fit = dict(out.get("fit") or {})
    if fit.get("kind") == "surfaces" and "surfaces" in out:
        entries = [dict(e) for e in out["surfaces"]]
        fitted = [e for e in entries if e.get("ok", True)]
        for e in fitted:
            e.setdefault("kind", surface_kind(e.get("model")))
        out["surfaces"] = entries
        if "surfaces" not in fit:
            kinds: dict[str, int] = {}
            for e in fitted:
                kinds[e["kind"]] = kinds.get(e["kind"], 0) + 1
            reason = fit.get("reason")
            fit = {
                "kind": "surfaces",
                "ok": bool(fitted),
                "surfaces": len(fitted),
                "failed": len(entries) - len(fitted),
                "kinds": dict(sorted(kinds.items())),
            }
            if not fitted:
                fit["reason"] = reason
    out["fit"] = fit
    return out


def read_report(path: str | Path) -> dict[str, Any]:
    """Read a ``report.json`` (a file or its directory) of any version, in today's shape.

    Raises
    ------
    InputError
        The file is missing or is not a report.
    """
    from sonarproc.errors import InputError

    p = Path(path)
    p = p / "report.json" if p.is_dir() else p
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise InputError(f"{p}: not a readable report.json ({err})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{p}: not a sonarproc report (not a JSON object)")
    return upgrade_report(doc)


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
    ahead: AheadFigures | None = None,
) -> dict[str, Any]:
    """Write the files of :func:`report_files` into ``out_dir``; return the report dict.

    ``auto``: the ``--auto`` record (report.json's ``auto``, a section of report.html);
    ``figures``: the figure formats (``png``, ``svg``; empty: no figures); ``ahead``: the
    figures being drawn in a child (:class:`sonarproc.report.ahead.AheadFigures`), used
    when drawn for this result, formats and record, else drawn here.
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
    drawn = ahead.collect(result, figures, auto) if ahead is not None else None
    if drawn is None:
        drawn = plots.render_figures(result, figures, auto=auto)
    for name, data in drawn.items():
        (out / name).write_bytes(data)
    (out / "report.html").write_text(render_html(doc, drawn), encoding="utf-8")
    log.info("wrote report to %s", out)
    return doc
