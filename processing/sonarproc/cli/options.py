"""Command-line options shared by ``run``, ``watch``, ``compare``, ``export``, ``sweep`` and
``batch``.

One definition per option (typer ``Annotated`` aliases) so that the commands describe and
parse the map and fit parameters the same way, and one place turning them into
:class:`~sonarproc.params.RunParams`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from sonarproc.errors import ParameterError

if TYPE_CHECKING:
    from sonarproc.params import RunParams
    from sonarproc.run_modes import RunMode

__all__ = [
    "ArcStepOption",
    "BboxOption",
    "CellOption",
    "CentreOption",
    "DropCrosstalkOption",
    "EngineOption",
    "FiguresOption",
    "FitOption",
    "NoAlignOption",
    "OpsOption",
    "OrderOption",
    "PoseFrameOption",
    "RobotOption",
    "RobustOption",
    "RunFitOption",
    "RunOpsOption",
    "RunRobustOption",
    "SensorsOption",
    "SmoothOption",
    "SpanOption",
    "TruthOption",
    "WorkersOption",
    "build_run_params",
    "worker_count",
]

CellOption = Annotated[float, typer.Option(help="Grid cell size (m).")]
BboxOption = Annotated[
    str | None, typer.Option(help="Map extent 'xmin,xmax,ymin,ymax' (m); default: all arcs.")
]
FitOption = Annotated[
    str,
    typer.Option(
        help="Fit: auto (the paper's polynomial for one curve y = f(x), else one fit per "
        "surface), poly, spline or polar."
    ),
]
OrderOption = Annotated[
    str | None,
    typer.Option(
        help="Polynomial order m (default 9) or polar harmonics (16); 'auto': choose m "
        "by cross-validation on the points (poly)."
    ),
]
SmoothOption = Annotated[
    float | None, typer.Option(help="Spline smoothing; default: cross-validation.")
]
CentreOption = Annotated[
    str | None, typer.Option(help="Polar fit centre 'x,y' (m); default: mean robot position.")
]
SensorsOption = Annotated[
    Path | None, typer.Option(help="Sensors YAML: the mounts of a readings CSV or a bag.")
]
OpsOption = Annotated[
    str,
    typer.Option(
        help="Operations on the arc map (the paper's method), e.g. 'closing,thinning:3' or "
        "'vote:auto,ridge'."
    ),
]
RobotOption = Annotated[
    str | None,
    typer.Option(help="Mount preset of a bag or CSV log (pioneer3-dx, nomad200-ring, ...)."),
]
TruthOption = Annotated[
    Path | None, typer.Option(help="True profile CSV (x,y) to compute E1 and E2 against.")
]
PoseFrameOption = Annotated[
    str | None,
    typer.Option(
        "--pose-frame",
        help="A bag's poses in this fixed frame of its tf tree (e.g. map: a SLAM's "
        "correction composed with the odometry, map -> odom -> base_link).",
    ),
]
NoAlignOption = Annotated[
    bool,
    typer.Option(
        "--no-align",
        help="Map the logged poses as they are (default: correct odometry drift where the "
        "echoes show it).",
    ),
]
DropCrosstalkOption = Annotated[
    bool, typer.Option("--drop-crosstalk", help="Skip readings flagged as crosstalk.")
]
RobustOption = Annotated[
    str,
    typer.Option(
        help="Polynomial fit: 'none' (the paper's least squares) or 'huber' (robust, "
        "over the points, weighted by their arc counts)."
    ),
]
#: ``run``'s own forms of the fit knobs: left out (``None``), they let the log choose the fit
#: (:mod:`sonarproc.run_modes`); named, they are used as given.
RunOpsOption = Annotated[
    str | None,
    typer.Option(
        "--ops",
        help="Operations on the arc map, e.g. 'closing,thinning:3' or 'vote:auto,ridge' "
        "(default: the paper's thinning:3).",
    ),
]
RunFitOption = Annotated[
    str | None,
    typer.Option(
        "--fit",
        help="Fit: auto (a polynomial for one curve y = f(x), else one fit per surface), "
        "poly, spline or polar. Left out: one curve's fit is chosen as --auto chooses it.",
    ),
]
RunRobustOption = Annotated[
    str | None,
    typer.Option(
        "--robust",
        help="Polynomial fit: 'none' (the paper's least squares, default) or 'huber' "
        "(robust, over the points, weighted by their arc counts).",
    ),
]
SpanOption = Annotated[
    str,
    typer.Option(
        help="Metric columns: 'truth' (all the truth spans in the map, the paper) or "
        "'points' (only between the first and last column with points)."
    ),
]

FiguresOption = Annotated[
    str,
    typer.Option(
        "--figures",
        metavar="FORMATS",
        help="Figure files to write: png (default), png,svg (vector copies for print), svg, "
        "or none (no figure; fastest).",
    ),
]

ArcStepOption = Annotated[
    float | None,
    typer.Option(
        "--arc-step",
        metavar="DEG",
        help="Draw each arc paper-style as samples every DEG degrees (one cell per "
        "sample, gaps allowed); default: gap-free 8-connected arcs.",
    ),
]


def _parse_order(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise ParameterError("order", f"must be an integer or 'auto', got {text!r}") from None


def build_run_params(
    *,
    cell: float,
    bbox: str | None,
    ops: str | None,
    fit: str | None,
    order: str | int | None,
    smooth: float | None = None,
    centre: str | None = None,
    drop_crosstalk: bool = False,
    robust: str | None = None,
    span: str = "truth",
    arc_step_deg: float | None = None,
    align: bool = True,
) -> RunParams:
    """Validated run parameters from option values as typed on the command line.

    ``ops``, ``fit`` and ``robust`` left out (``None``) are the paper's: ``thinning:3``,
    ``auto`` (a polynomial for one curve, else surfaces) and ``none``.

    Raises
    ------
    ValueError
        A malformed bbox, centre or order, or a value :class:`RunParams` refuses
        (e.g. ``arc_step_deg <= 0``).
    """
    import math

    from sonarproc.params import PAPER_OPS, RunParams, parse_bbox, parse_point

    ops = PAPER_OPS if ops is None else ops
    fit = "auto" if fit is None else fit
    robust = "none" if robust is None else robust
    if not ops.strip():
        raise ParameterError(
            "ops", "is empty; give operations, e.g. 'thinning:3' or 'closing,thinning:2'"
        )
    auto_order = isinstance(order, str) and order.strip().lower() == "auto"
    if order is None or auto_order:
        order_value = None
    else:
        order_value = order if isinstance(order, int) else _parse_order(order)
    return RunParams(
        cell=cell,
        bbox=parse_bbox(bbox) if bbox is not None else None,
        ops=ops,
        fit=fit,  # type: ignore[arg-type]  # validated by RunParams
        order=order_value,
        smooth=smooth,
        centre=parse_point(centre) if centre is not None else None,
        drop_crosstalk=drop_crosstalk,
        auto_order=auto_order,
        robust=robust.strip().lower(),  # type: ignore[arg-type]  # validated by RunParams
        span=span.strip().lower(),  # type: ignore[arg-type]  # validated by RunParams
        arc_step=None if arc_step_deg is None else math.radians(arc_step_deg),
        align=align,
    )


EngineOption = Annotated[
    str,
    typer.Option(
        "--engine",
        metavar="ENGINE",
        help="Where the runs execute: local (a process pool), dask (a local Dask cluster) or "
        "dask=SCHEDULER_ADDRESS (an existing Dask cluster; needs the 'dask' extra).",
    ),
]
WorkersOption = Annotated[
    int,
    typer.Option(
        "--workers",
        "--jobs",
        metavar="N",
        help="Worker processes (0: one per CPU; 1 with --engine local: in this process). "
        "Ignored with a Dask scheduler address.",
    ),
]


def worker_count(workers: int) -> int:
    """``--workers``: a count >= 1 (0 means one per CPU).

    Raises
    ------
    ParameterError
        A negative count.
    """
    import os

    if workers < 0:
        raise ParameterError("workers", f"must be >= 0, got {workers}")
    return workers or (os.cpu_count() or 1)


def build_run_mode(*, auto: bool, paper: bool, **options: Any) -> tuple[RunMode, RunParams]:
    """How a run picks its fit (:func:`sonarproc.run_modes.resolve_mode`) and its parameters
    (:func:`build_run_params` of ``options``), from ``run``'s or ``batch``'s options.

    Raises
    ------
    ParameterError
        ``--paper`` with ``--auto`` or a fit option, or a value :func:`build_run_params`
        refuses.
    """
    from sonarproc.run_modes import FIT_KNOBS, resolve_mode

    mode = resolve_mode(auto=auto, paper=paper, knobs={k: options.get(k) for k in FIT_KNOBS})
    return mode, build_run_params(**options)
