"""The held-out range residual computed on the second core while the run fits its map.

The residual's refit (:func:`sonarproc.quality.measure.heldout_residual`: the map built
again without a tenth of the firings, fitted as the run fits) needs only the readings,
the grid, the parameters and the run's count map: all there as soon as the map is built,
before the run's own fit. So :meth:`HeldOutAhead.start` forks a child then
(:class:`sonarproc.forked.ForkedChild`), which computes the residual while this process
fits; :meth:`HeldOutAhead.residual` collects it as the quality stage starts. The child
sends back a handful of numbers.

The figures are the same as those computed here: the child runs the same code on the
same arrays (inherited, not copied or pickled), in the same process state (one BLAS
thread, as the command sets it before numpy loads). Where no child may be forked
(:func:`~sonarproc.forked.fork_is_safe`: Linux, two cores, one thread, no pool) or the
child fails, :meth:`~HeldOutAhead.residual` computes it here, as before.
"""

from __future__ import annotations

import contextlib
import os
from typing import Any

import numpy.typing as npt

from sonarproc.forked import AheadJob, fork_is_safe
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import MapBuilder
from sonarproc.pipeline.selection import Beams
from sonarproc.quality.measure import HeldOutResidual, held_out, heldout_residual

__all__ = ["CHILD_NICENESS", "HeldOutAhead"]

#: The child's niceness (added to the run's): with two cores, the run's fit and the
#: figure child's drawing come first, and the refit takes the time they leave (its
#: answer is collected only after the fit; the figures drawn after it leave a core free).
CHILD_NICENESS = 5


class HeldOutAhead(AheadJob):
    """The held-out residual of one map, computed in a forked child or, failing that, here.

    Parameters
    ----------
    build : MapBuilder
        The run's map builder.
    beams : Beams
        The readings the run mapped.
    grid : Grid
        The run's grid.
    params : RunParams
        The run's parameters.
    counts : ndarray or None
        The run's arc count map for the paper's builder (the training map is then made
        from it, :func:`~sonarproc.quality.measure.held_out`); None for any other.
    """

    def __init__(
        self,
        build: MapBuilder,
        beams: Beams,
        grid: Grid,
        params: RunParams,
        counts: npt.NDArray[Any] | None,
    ) -> None:
        super().__init__()
        self._args = (build, beams, grid, params, counts)

    @classmethod
    def start(
        cls,
        build: MapBuilder,
        beams: Beams,
        grid: Grid,
        params: RunParams,
        counts: npt.NDArray[Any] | None,
    ) -> HeldOutAhead:
        """The residual of this map, its child forked now where that is safe."""
        job = cls(build, beams, grid, params, counts)
        if fork_is_safe():
            job.fork(job._in_child)
        return job

    def _in_child(self) -> HeldOutResidual:
        # the run's fit, and the figures drawn meanwhile, are what the run waits for
        # first; the residual is wanted only as the quality stage starts, after both
        with contextlib.suppress(OSError):
            os.nice(CHILD_NICENESS)
        return self._compute()

    def _compute(self) -> HeldOutResidual:
        build, beams, grid, params, counts = self._args
        return heldout_residual(held_out(beams, grid, params, counts), build, beams, grid, params)

    def residual(self) -> HeldOutResidual:
        """The child's residual, or the residual computed here (no child, or it failed)."""
        got = self.collect()
        return got if isinstance(got, HeldOutResidual) else self._compute()
