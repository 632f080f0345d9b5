"""A run's figures drawn ahead, in a forked child, while the run measures its quality.

The figures (:func:`sonarproc.report.plots.render_figures`) show the run's maps, fit and
metrics, never its truth-free quality, which is measured last and is one of the run's
longest stages. :func:`draw_ahead` forks a child as that stage starts: the child has the
result as it stands then (a fork shares the maps, nothing is copied or pickled on the way
in), imports matplotlib and draws on the second core while this process measures; the
report collects the bytes (:meth:`AheadFigures.collect`). They are the bytes
:func:`~sonarproc.report.plots.render_figures` gives on the finished result, because
nothing a figure shows changes after the fork (tested).

Nothing is forked where a fork is unsafe or gains nothing
(:func:`~sonarproc.report.drawing.fork_is_safe`: Linux, one thread, two cores, no pool):
the report then draws its figures itself, as it does when the child fails or the result
it drew is not the one reported.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

from sonarproc.pipeline.result import RunResult
from sonarproc.report.drawing import DrawingChild, fork_is_safe

__all__ = ["AheadFigures", "draw_ahead"]

log = logging.getLogger(__name__)


class AheadFigures:
    """Figures being drawn in a forked child for one result, formats and ``--auto`` record."""

    def __init__(
        self,
        child: DrawingChild,
        result: RunResult,
        formats: tuple[str, ...],
        auto: Mapping[str, Any] | None,
    ) -> None:
        self._child: DrawingChild | None = child
        self._drawn_for = (result, formats, auto)

    def collect(
        self,
        result: RunResult,
        formats: Sequence[str],
        auto: Mapping[str, Any] | None = None,
    ) -> dict[str, bytes] | None:
        """The figures' bytes, as :func:`~sonarproc.report.plots.render_figures` of
        ``result`` in ``formats`` with ``auto`` gives them; None when the child failed,
        was collected already, or drew another result (it is then stopped)."""
        child, self._child = self._child, None
        if child is None:
            return None
        drawn_result, drawn_formats, drawn_auto = self._drawn_for
        if drawn_result is not result or drawn_formats != tuple(formats) or drawn_auto != auto:
            child.cancel()
            return None
        return child.collect()

    def cancel(self) -> None:
        """Stop the child, if it still runs: its figures are not wanted."""
        child, self._child = self._child, None
        if child is not None:
            child.cancel()


def draw_ahead(
    result: RunResult,
    formats: Sequence[str],
    *,
    auto: Mapping[str, Any] | None = None,
) -> AheadFigures | None:
    """Start drawing ``result``'s figures in ``formats`` in a forked child.

    Returns
    -------
    AheadFigures or None
        The child's figures to collect; None when there is nothing to draw or no child
        may be forked (the report then draws them itself).
    """
    from sonarproc.report.plots import render_figures

    shown = tuple(formats)
    if not shown or not fork_is_safe():
        return None
    child = DrawingChild.start_work(lambda: render_figures(result, shown, auto=auto))
    if child is None:
        return None
    log.debug("figures: drawn ahead in child %d", child.pid)
    return AheadFigures(child, result, shown, auto)
