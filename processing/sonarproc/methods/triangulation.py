"""Triangulation-based fusion (Wijk & Christensen 2000).

Wijk & Christensen (IEEE T-RA 2000, "Triangulation-based fusion of sonar data with
application in robot pose tracking"): two readings taken from nearby positions that see
the same reflector put it where their range circles cross, inside both beams; crossings
that several pairs of readings agree on are kept, lone ones (spurious echoes, wrong
pairings) are not.

Here each reading is a circle about its apex (the transducer, or the midpoint of a
bistatic pair) with the line-of-sight range as radius
(:func:`~sonarproc.methods.geometry.axis_points`). Readings are sorted by apex and each
is paired with its ``neighbours`` successors whose apex lies between ``min_baseline`` and
``max_baseline`` away. Crossings inside both beams are counted per cell, and a cell is
kept when its 3 x 3 neighbourhood holds at least ``min_support`` crossings. All pairs
are formed and intersected at once (numpy, no loop per reading).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from sonarproc.errors import ParameterError
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MapMethod, MethodMap, OptionValue
from sonarproc.methods.geometry import axis_points
from sonarproc.params import RunParams

__all__ = ["Triangulation", "crossings"]

FloatArray = npt.NDArray[np.float64]


def _in_beam(
    p: FloatArray, apex: FloatArray, u: FloatArray, half: FloatArray
) -> npt.NDArray[np.bool_]:
    d = p - apex
    along = d[:, 0] * u[:, 0] + d[:, 1] * u[:, 1]
    across = np.abs(d[:, 1] * u[:, 0] - d[:, 0] * u[:, 1])
    return (along > 0) & (across <= along * np.tan(half))


def crossings(
    beams: Beams, *, neighbours: int, min_baseline: float, max_baseline: float
) -> FloatArray:
    """Crossing points ``(K, 2)`` of the range circles of nearby readings, inside both beams."""
    poses = beams.poses
    apex, u, dist = axis_points(
        poses.tx_xy, poses.tx_heading, poses.rx_xy, poses.rx_heading, beams.path
    )
    half = np.minimum(poses.tx_half_beamwidth, poses.rx_half_beamwidth)
    ok = np.flatnonzero(np.isfinite(dist))
    order = ok[np.lexsort((apex[ok, 1], apex[ok, 0]))]
    n = order.size
    out: list[FloatArray] = []
    for k in range(1, min(neighbours, n - 1) + 1):
        i, j = order[: n - k], order[k:]
        c1, c2 = apex[i], apex[j]
        r1, r2 = dist[i], dist[j]
        dv = c2 - c1
        d = np.hypot(dv[:, 0], dv[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
            h2 = r1 * r1 - a * a
        good = (d >= min_baseline) & (d <= max_baseline) & (h2 >= 0)
        if not np.any(good):
            continue
        i, j, c1, dv, d, a = i[good], j[good], c1[good], dv[good], d[good], a[good]
        h = np.sqrt(h2[good])
        e = dv / d[:, None]
        base = c1 + a[:, None] * e
        perp = np.column_stack((-e[:, 1], e[:, 0]))
        for sign in (1.0, -1.0):
            p = base + sign * h[:, None] * perp
            keep = _in_beam(p, apex[i], u[i], half[i]) & _in_beam(p, apex[j], u[j], half[j])
            out.append(p[keep])
    return np.concatenate(out) if out else np.zeros((0, 2))


class Triangulation(MapMethod):
    """Triangulation-based fusion (Wijk & Christensen 2000): supported circle crossings.

    Examples
    --------
    A right-angle corner: the supported crossings lie on its two walls.

    >>> from sonarproc.methods.testing import corner_beams
    >>> beams, grid = corner_beams()
    >>> m = Triangulation().build(beams, grid, RunParams())
    >>> iy, ix = np.nonzero(m.processed)
    >>> x, y = grid.to_world(iy, ix)
    >>> bool(m.processed.any() and np.all(np.minimum(2 - x, 2 - y) < 0.05))
    True
    """

    name: ClassVar[str] = "triangulation"
    summary: ClassVar[str] = "crossings of nearby readings' circles (Wijk & Christensen 2000)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {
        "neighbours": 12,
        "min_baseline": 0.02,
        "max_baseline": 0.6,
        "min_support": 3,
    }

    def validate(self) -> None:
        o = self.options
        if int(o["neighbours"]) < 1 or int(o["min_support"]) < 1:
            raise ParameterError(self.name, "options neighbours and min_support must be >= 1")
        if not 0 <= float(o["min_baseline"]) < float(o["max_baseline"]):
            raise ParameterError(self.name, "option min_baseline must be in [0, max_baseline)")

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        o = self.options
        pts = crossings(
            beams,
            neighbours=int(o["neighbours"]),
            min_baseline=float(o["min_baseline"]),
            max_baseline=float(o["max_baseline"]),
        )
        iy, ix = grid.to_index(pts[:, 0], pts[:, 1])
        inside = grid.contains_index(iy, ix)
        flat = np.bincount(iy[inside] * grid.nx + ix[inside], minlength=grid.ny * grid.nx)
        hits = flat.reshape(grid.shape)
        # imported here: the registry loads every method, and a run maps with one
        from scipy import ndimage

        support = ndimage.uniform_filter(hits.astype(np.float64), size=3, mode="constant") * 9
        keep = (hits > 0) & (support >= int(o["min_support"]) - 0.5)
        return MethodMap(keep, hits.astype(np.uint32))
