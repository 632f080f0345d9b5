"""The Python API: run the method on a log, compare methods, read a log.

The options are those of ``sonarproc run``, by the same names (``cell``, ``ops``, ``fit``,
``order``, ``smooth``, ``centre``, ``bbox``, ``drop_crosstalk``, ``robust``, ``span``,
``arc_step`` in degrees), with the same defaults and the same validation: they go through
:func:`sonarproc.cli.options.build_run_params`, the one place that turns options into
:class:`~sonarproc.params.RunParams`. ``bbox`` and ``centre`` may also be sequences of
numbers.

>>> import sonarproc
>>> sorted(sonarproc.__all__)
['RunResult', '__version__', 'compare', 'read_log', 'run']
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.errors import ParameterError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from sonarlog import SonarLog
    from sonarproc.params import RunParams
    from sonarproc.pipeline import RunResult as RunRecord
    from sonarproc.surfaces import SurfaceFit

__all__ = ["FIGURES", "RUN_OPTIONS", "RunResult", "compare", "read_log", "run"]

#: The options :func:`run` and :func:`compare` take (``sonarproc run``'s, same names).
RUN_OPTIONS = (
    "cell", "bbox", "ops", "fit", "order", "smooth", "centre", "drop_crosstalk", "robust",
    "span", "arc_step", "no_align",
)  # fmt: skip
#: The figures :meth:`RunResult.figure` draws (those of a report directory).
FIGURES = ("arcmap", "processed", "fit")
#: The keys of :attr:`RunResult.metrics`, when defined.
_METRIC_KEYS = ("e", "f_c", "t_cpu_s", "E1_m", "E2", "precision_m", "completeness")


@dataclass(frozen=True, eq=False)
class RunResult:
    """The result of one run, as the API gives it.

    Attributes
    ----------
    record : sonarproc.pipeline.RunResult
        Everything the run produced (maps, points, fit, counts, timings): what the report
        writers read.
    method : str
        ``morphological`` for :func:`run`; the method's name for :func:`compare`.
    auto : dict or None
        Where ``--auto``'s choice made the result (``auto=True``, or a one-curve log run
        with default options), the record of the choice (``report.json``'s ``auto``).
    """

    record: RunRecord
    method: str = "morphological"
    auto: dict[str, Any] | None = field(default=None)

    @property
    def surfaces(self) -> list[SurfaceFit]:
        """The fitted surfaces, longest first (empty for a single-curve fit)."""
        s = self.record.surfaces
        return [] if s is None else list(s.surfaces)

    @property
    def profile(self) -> npt.NDArray[np.float64] | None:
        """The fitted profile as an ``(N, 2)`` array sampled every cell (m), or None.

        None when there is no single profile: the fit failed, or the map was fitted as
        several surfaces (see :attr:`surfaces`).
        """
        from sonarproc.report.run_report import profile_points

        pts = profile_points(self.record)
        return pts if pts.size else None

    @property
    def metrics(self) -> dict[str, float]:
        """``e``, ``f_c``, ``t_cpu_s``; ``E1_m``, ``E2``, ``precision_m``, ``completeness``
        when defined (with a truth profile), as in ``report.json``."""
        from sonarproc.report.run_report import report_dict

        m = report_dict(self.record)["metrics"]
        return {k: m[k] for k in _METRIC_KEYS if m.get(k) is not None}

    @property
    def quality(self) -> dict[str, Any] | None:
        """The truth-free quality figures (``report.json``'s ``quality``: explained
        fraction within 5 cm, overall and per surface, held-out range residual median and
        90th percentile), or None when the run did not measure them."""
        q = self.record.quality
        return None if q is None else q.to_json()

    @property
    def alignment(self) -> dict[str, Any] | None:
        """The drift correction's record (``report.json``'s ``alignment``), or None when
        it was not tried (``no_align=True``)."""
        a = self.record.alignment
        return None if a is None else a.to_json()

    def figure(self, name: str = "fit") -> Figure:
        """One of the report's figures as a matplotlib Figure: ``arcmap``, ``processed``, ``fit``.

        Raises
        ------
        ParameterError
            An unknown name (the message lists the names).
        """
        if name not in FIGURES:
            raise ParameterError("figure", f"must be one of {', '.join(FIGURES)}, got {name!r}")
        from sonarproc.report import plots

        fig: Figure = getattr(plots, f"{name}_figure")(self.record)
        return fig


def _cli_defaults() -> dict[str, Any]:
    """``sonarproc run``'s defaults, read from the command so the two cannot drift."""
    from sonarproc.cli.run import run_command

    params = inspect.signature(run_command).parameters
    return {name: params[name].default for name in RUN_OPTIONS}


def _as_text(value: Any) -> Any:
    if isinstance(value, Sequence) and not isinstance(value, str):
        return ",".join(repr(float(v)) for v in value)
    return value


def run_params(**options: Any) -> RunParams:
    """Validated :class:`~sonarproc.params.RunParams` from ``sonarproc run``'s options.

    Raises
    ------
    ParameterError
        An unknown option (the message lists the options) or a value the command line
        would refuse.
    """
    from sonarproc.cli.options import build_run_params

    unknown = sorted(set(options) - set(RUN_OPTIONS))
    if unknown:
        raise ParameterError(unknown[0], f"is not an option (options: {', '.join(RUN_OPTIONS)})")
    values = {**_cli_defaults(), **options}
    return build_run_params(
        cell=float(values["cell"]), bbox=_as_text(values["bbox"]),
        ops=values["ops"], fit=values["fit"], order=values["order"],
        smooth=values["smooth"], centre=_as_text(values["centre"]),
        drop_crosstalk=bool(values["drop_crosstalk"]), robust=values["robust"],
        span=values["span"], arc_step_deg=values["arc_step"],
        align=not bool(values["no_align"]),
    )  # fmt: skip


def read_log(
    path: str | Path,
    *,
    sensors: str | Path | None = None,
    truth: str | Path | None = None,
    robot: str | None = None,
    degrees: bool = False,
) -> SonarLog:
    """Read any log ``sonarproc run`` reads (sonarlog, readings CSV, ROS bag, Player log).

    Parameters
    ----------
    path : path-like
        The log. A readings CSV needs ``sensors`` (a YAML) or ``robot`` (a preset).
    sensors, robot : optional
        The mounts of a CSV, bag or Player log.
    truth : path-like, optional
        A truth CSV replacing the log's ``/truth/profile``.
    degrees : bool
        A readings CSV's ``theta`` and ``turret`` are in degrees.

    Returns
    -------
    sonarlog.SonarLog
    """
    from sonarproc.pipeline import load_log

    return load_log(path, sensors=sensors, truth=truth, robot=robot, degrees=degrees)


def _log(log: str | Path | SonarLog, read: dict[str, Any]) -> SonarLog:
    if isinstance(log, (str, Path)):
        return read_log(log, **read)
    if read.get("truth") is not None:
        from sonarlog.csvlog import read_truth_csv

        return replace(log, truth=read_truth_csv(read["truth"]))
    return log


def run(
    log: str | Path | SonarLog,
    *,
    auto: bool = False,
    paper: bool = False,
    sensors: str | Path | None = None,
    truth: str | Path | None = None,
    robot: str | None = None,
    degrees: bool = False,
    **options: Any,
) -> RunResult:
    """Run the method on a log: ``sonarproc run`` without the report files.

    Parameters
    ----------
    log : path-like or sonarlog.SonarLog
        A log path (any kind :func:`read_log` reads) or a log in memory.
    auto : bool
        Choose the method, operations and fit without ground truth on any log (``--auto``).
    paper : bool
        The paper's method exactly (``--paper``): ``ops="thinning:3"``, a polynomial of
        order 9 for one curve.
    sensors, truth, robot, degrees
        As for :func:`read_log`.
    **options
        ``sonarproc run``'s options (:data:`RUN_OPTIONS`), e.g. ``fit="poly", order=9``.
        With none of ``ops``, ``fit``, ``order``, ``smooth``, ``robust`` (and neither
        ``auto`` nor ``paper``), a one-curve log's fit is chosen as ``auto`` chooses it
        and a room's surfaces are fitted one by one, as ``sonarproc run`` does
        (:mod:`sonarproc.run_modes`).

    Returns
    -------
    RunResult

    Raises
    ------
    ParameterError
        An unknown option or a bad value (one line naming it).
    FileNotFoundError, sonarlog.SonarLogError, NothingToMapError
        As ``sonarproc run``.
    """
    from sonarproc.run_modes import FIT_KNOBS, resolve_mode, run_log

    mode = resolve_mode(auto=auto, paper=paper, knobs={k: options.get(k) for k in FIT_KNOBS})
    params = run_params(**options)
    read = {"sensors": sensors, "truth": truth, "robot": robot, "degrees": degrees}
    source = log if isinstance(log, (str, Path)) else _log(log, read)
    result, record = run_log(source, params, mode, read=read)
    return RunResult(result, "auto" if record is not None else "morphological", record)


def compare(
    log: str | Path | SonarLog,
    methods: Sequence[str] | str | None = None,
    *,
    sensors: str | Path | None = None,
    truth: str | Path | None = None,
    robot: str | None = None,
    degrees: bool = False,
    **options: Any,
) -> dict[str, RunResult]:
    """Run several map-building methods on one log with the same grid, fit and metrics.

    Parameters
    ----------
    log : path-like or sonarlog.SonarLog
        As for :func:`run`.
    methods : sequence of str, or str, optional
        Method names (``"morphological,arc-median"`` or a list); default: all of
        ``sonarproc compare``'s.
    sensors, truth, robot, degrees, **options
        As for :func:`run`.

    Returns
    -------
    dict
        Method name to its :class:`RunResult`, in the order run.
    """
    from sonarproc.methods import DEFAULT_METHODS, make_method, parse_method_list
    from sonarproc.methods.compare import compare as compare_methods

    params = run_params(**options)
    if methods is None:
        names = list(DEFAULT_METHODS)
    else:
        names = parse_method_list(methods if isinstance(methods, str) else ",".join(methods))
    instances = [make_method(n) for n in names]
    lg = _log(log, {"sensors": sensors, "truth": truth, "robot": robot, "degrees": degrees})
    results = compare_methods(lg, params, instances)
    return {r.method: RunResult(r.run, r.method) for r in results}
