"""How ``sonarproc run`` picks its operations and fit: given, chosen by ``--auto``, or the default.

Three modes, one per way a user calls ``run``:

* ``given``: the operations and fit the user named (``--ops``, ``--fit``, ``--order``,
  ``--smooth``, ``--robust``), the paper's where one is left out. ``--paper`` is this mode
  with every knob at the paper's value (``thinning:3``, a polynomial of order 9).
* ``auto``: :func:`sonarproc.auto.run_auto` chooses the map method, its operations and the
  fit by the held-out range residual, on every log (a room included).
* ``default`` (no knob named): the paper's map is built and split into surfaces as in
  ``given``. Where it holds several surfaces (a room, a corridor) each is fitted with a
  line, an arc or a spline, which needs no choosing; where it is one curve y = f(x), the
  fit is chosen as ``auto`` chooses it.

Why the default chooses: no fixed operations and polynomial order suit every log. The
order a curve needs depends on how many extrema the surface has over the scanned span,
and the operations that keep a curve's cells depend on how densely and how noisily the
arcs cross it; both are properties of the log, not of the method. The held-out range
residual measures them from the log itself (no ground truth), so the default asks it. A
room keeps the surfaces fit, whose lines, arcs and splines need no order, and so costs
what it did.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from sonarproc.errors import ParameterError

if TYPE_CHECKING:
    from collections.abc import Callable

    from sonarlog import SonarLog
    from sonarproc.params import RunParams
    from sonarproc.pipeline import RunResult
    from sonarproc.pipeline.mapping import MappedStage

__all__ = ["FIT_KNOBS", "RunMode", "resolve_mode", "run_log"]

RunMode = Literal["given", "auto", "default"]

#: The options that pick the operations and the fit; naming any of them means ``given``.
FIT_KNOBS = ("ops", "fit", "order", "smooth", "robust")


def resolve_mode(*, auto: bool, paper: bool, knobs: dict[str, Any]) -> RunMode:
    """The mode of a run from its flags and the fit knobs the user named.

    Parameters
    ----------
    auto : bool
        ``--auto`` was given.
    paper : bool
        ``--paper`` was given.
    knobs : dict
        The :data:`FIT_KNOBS` the user named (``None`` values are not named).

    Returns
    -------
    {"given", "auto", "default"}

    Raises
    ------
    ParameterError
        ``--auto`` with ``--paper``, or ``--paper`` with a fit knob.
    """
    named = sorted(k for k, v in knobs.items() if v is not None)
    if auto and paper:
        raise ParameterError("paper", "cannot be combined with --auto: choose one")
    if paper and named:
        raise ParameterError(
            "paper", f"fixes the operations and the fit; drop --{named[0]} or --paper"
        )
    if auto:
        return "auto"
    return "given" if paper or named else "default"


def run_log(
    source: SonarLog | str | Path,
    params: RunParams,
    mode: RunMode,
    *,
    read: dict[str, Any] | None = None,
    progress: Any = None,
    on_fitted: Callable[[RunResult], None] | None = None,
    on_mapped: Callable[[MappedStage], None] | None = None,
) -> tuple[RunResult, dict[str, Any] | None]:
    """Run a log in ``mode``: the result, and ``--auto``'s record where a choice was made.

    Parameters
    ----------
    source : sonarlog.SonarLog or path-like
        The readings, or a log file :func:`sonarproc.pipeline.load_log` reads (its reading
        time is then in ``timings_s["read"]`` and ``t_cpu_s``, as with
        :func:`sonarproc.pipeline.run_file`).
    params : RunParams
        The run's parameters (in ``default`` mode the paper's operations and ``fit="auto"``).
    mode : {"given", "auto", "default"}
        See the module's description.
    read : dict, optional
        Keyword arguments of :func:`sonarproc.pipeline.load_log` (``sensors``, ``truth``,
        ``robot``, ``degrees``, ``pose_frame``) for a path.
    progress : callable, optional
        Called with each stage's name, as :func:`sonarproc.pipeline.process` does.
    on_fitted : callable, optional
        Called with the result before its quality is measured, where that result is the
        one returned with no record (see :func:`sonarproc.pipeline.process`).
    on_mapped : callable, optional
        Called with the map as it is built, before its fit, outside ``--auto``
        (see :func:`sonarproc.pipeline.process`).

    Returns
    -------
    result : RunResult
    record : dict or None
        report.json's ``auto`` (with ``"mode"``: ``auto`` or ``default``); ``None`` where
        the operations and fit were given, or the default's map held several surfaces.
    """
    import time

    from sonarproc.pipeline import load_log, process
    from sonarproc.pipeline.align_ahead import AlignAhead
    from sonarproc.pipeline.run import import_stage_modules

    import_stage_modules(params)  # start-up, not the run's CPU time
    cpu0 = time.process_time()
    wall0 = time.perf_counter()
    if isinstance(source, (str, Path)):
        if progress is not None:
            progress("read")
        log_ = load_log(source, **(read or {}))
    else:
        log_ = source
    read_s = time.perf_counter() - wall0
    aligned = None
    if mode == "default" and params.align:
        # aligned once (in a child while the log is mapped, where it may): a one-curve
        # map is handed on to --auto with these same poses
        aligned = AlignAhead.start(log_, progress)
    if mode != "auto":
        result = process(
            log_,
            params,
            progress=progress,
            cpu_start=cpu0,
            aligned=aligned,
            quality_of_curves=mode == "given",
            on_fitted=on_fitted,
            on_mapped=on_mapped,
        )
        result.timings_s = {"read": read_s, **result.timings_s}
        if mode == "given" or result.surfaces is not None:
            return result, None
    from sonarproc.quality.of_auto import run_auto_measured

    chosen_run, chosen, choice = run_auto_measured(
        log_, params, aligned.result() if aligned is not None else None
    )
    record = choice.to_json(chosen)
    record["mode"] = mode
    return chosen_run.run, record
