"""Free space: where the readings' beams passed without echoing, and distinct viewpoints.

A reading with range ``r`` along a beam of half-width ``beta`` says that the cone in front
of its sensor, up to ``r`` less a margin, held no reflector that would have echoed first.
A straight wall echoes specularly, from the one point where its normal points at the
sensor (the *foot* of the sensor on the wall's line). So a wall standing at the foot,
with the foot inside the beam, would have returned an echo at the foot's distance ``d``.
When the measured range reaches beyond every point of that line in the beam
(``r > d / cos(beta) + margin``), the wall is absent at the foot: the reading *saw
through* the line there, and the foot is a *free foot*.

The margin is the range tolerance of the caller (range noise, the board's range
quantisation and the time walk of weak echoes, a few centimetres), so that an echo from
the wall itself never counts as free. A real transducer hears a plane over a beam that
narrows with range (below the nominal half-width beyond about 1.5 m for a Polaroid
sensor), and a plane near the nominal edge of the beam may not be heard at all at a few
metres: its missing echo is no evidence. Only feet within :data:`FREE_BEAM_FRACTION` of
the nominal half-width count; inside half the beam a Polaroid sensor hears a head-on
plane to about 5 m, beyond the ranges the logs keep.

One reading may be a missed or late echo (a dropout, a stray echo from behind), so the
callers ask for free feet from :data:`MIN_FREE_POSES` distinct viewpoints before they
treat a stretch of line as open. Viewpoints are the readings' sensor positions on a
grid of :data:`VIEWPOINT_STEP_M`: readings taken from positions closer than the range
resolution of the board (one inch) give the same arcs, and a robot standing still and
ranging the same wall again adds readings but no new view of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

__all__ = [
    "FREE_BEAM_FRACTION",
    "MIN_FREE_POSES",
    "VIEWPOINT_STEP_M",
    "FreeCones",
    "distinct_viewpoints",
    "free_feet",
    "viewpoint_ids",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Share of the nominal half beam width inside which a missing wall echo is evidence.
FREE_BEAM_FRACTION = 0.5
#: Grid step (m) on which sensor positions are told apart as viewpoints (one inch).
VIEWPOINT_STEP_M = 0.0254
#: Distinct viewpoints whose free feet open a stretch of line.
MIN_FREE_POSES = 2
#: Segment x reading pairs tested at once, at most (bounds the memory).
_CHUNK_PAIRS = 2_000_000


def viewpoint_ids(xy: npt.ArrayLike, step: float = VIEWPOINT_STEP_M) -> IntArray:
    """One id per distinct viewpoint: the sensor position's cell on a grid of ``step`` m.

    The ids are not consecutive (each is its cell's two indices in one integer, so no
    sort is needed); equal ids are one viewpoint.

    Examples
    --------
    >>> v = viewpoint_ids([[0.0, 0.0], [0.001, 0.002], [0.5, 0.0], [-0.5, 0.0]])
    >>> bool(v[0] == v[1]), np.unique(v).size
    (True, 3)
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    cells = np.floor(p / step)
    cells = np.where(np.isfinite(cells), cells, 0.0).astype(np.int64)
    # the row index above 2^32, the column index (from -2^31) below: one integer per cell
    return np.asarray(cells[:, 0] * (1 << 32) + cells[:, 1], dtype=np.intp)


@dataclass(frozen=True, eq=False)
class FreeCones:
    """The readings as free cones: sensor position, heading, half beam, range, viewpoint."""

    xy: FloatArray
    heading: FloatArray
    half_beam: FloatArray
    range_m: FloatArray
    viewpoint: IntArray

    @classmethod
    def of(
        cls, xy: npt.ArrayLike, heading: npt.ArrayLike, half_beam: npt.ArrayLike,
        range_m: npt.ArrayLike,
    ) -> FreeCones:  # fmt: skip
        """From the readings' arrays (SI); viewpoints from :func:`viewpoint_ids`."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return cls(p, np.asarray(heading, dtype=np.float64).ravel(),
                   np.asarray(half_beam, dtype=np.float64).ravel(),
                   np.asarray(range_m, dtype=np.float64).ravel(), viewpoint_ids(p))  # fmt: skip

    @property
    def size(self) -> int:
        """Number of readings."""
        return int(self.range_m.size)

    @cached_property
    def axes(self) -> tuple[FloatArray, FloatArray]:
        """The cosine and the sine of every heading, computed once: the free-space tests
        screen all the readings by them, once per line tried."""
        return np.cos(self.heading), np.sin(self.heading)

    @cached_property
    def free_cones(self) -> tuple[FloatArray, FloatArray]:
        """Each reading's free cone (:data:`FREE_BEAM_FRACTION` of its half beam, rad), and
        a bound under the cosine of every direction inside it, computed once.

        The bound, for a screen by dot products of unit vectors (:attr:`axes`): the cone's
        cosine less 1e-9 (far above a dot product's rounding, a few 1e-16); -2 (every
        direction) from a half turn on; +inf (none) for a reading without a finite range.
        """
        cone = FREE_BEAM_FRACTION * self.half_beam
        bound = np.where(cone < np.pi, np.cos(np.minimum(cone, np.pi)) - 1e-9, -2.0)
        return cone, np.where(np.isfinite(self.range_m), bound, np.inf)


def free_feet(
    a: npt.ArrayLike, b: npt.ArrayLike, cones: FreeCones, *, margin: float
) -> tuple[IntArray, IntArray, FloatArray]:
    """The free feet of the readings on straight segments ``a -> b`` (module notes).

    Parameters
    ----------
    a, b : array_like, shape (S, 2)
        Segment ends.
    cones : FreeCones
        The readings.
    margin : float
        Range tolerance (m): the range must exceed the line's farthest point in the beam
        by more than this.

    Returns
    -------
    segment, reading : ndarray of int, shape (F,)
        The segment and the reading of each free foot.
    along : ndarray, shape (F,)
        The foot's distance (m) from the segment's start ``a``.

    Examples
    --------
    A wall along y = 1 from x = 0 to 2; a sensor below x = 1.5 looking up ranges 3 m
    (it saw through), one below x = 0.5 ranges 1 m (it heard the wall):

    >>> c = FreeCones.of([[1.5, 0.0], [0.5, 0.0]], [np.pi / 2] * 2, [0.2] * 2, [3.0, 1.0])
    >>> seg, read, along = free_feet([[0.0, 1.0]], [[2.0, 1.0]], c, margin=0.03)
    >>> seg.tolist(), read.tolist(), np.round(along, 6).tolist()
    ([0], [0], [1.5])
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    empty = (np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0))
    n = cones.size
    if a.shape[0] == 0 or n == 0:
        return empty
    chord = b - a
    length = np.hypot(*chord.T)
    t = chord / np.maximum(length, 1e-300)[:, None]
    cone = FREE_BEAM_FRACTION * cones.half_beam
    # the foot's direction from a sensor is the line's normal (-ty, tx) or its opposite:
    # the beam test needs only the headings, and leaves few pairs for the rest
    normal = np.arctan2(t[:, 0], -t[:, 1])
    segs, reads, alongs = [], [], []
    step = max(1, _CHUNK_PAIRS // max(a.shape[0], 1))
    for r0 in range(0, n, step):
        h = cones.heading[r0 : r0 + step]
        off = (normal[:, None] - h[None, :]) % (2 * math.pi)  # 0 .. 2 pi
        cone_j = cone[r0 : r0 + step][None, :]
        plus = (off <= cone_j) | (off >= 2 * math.pi - cone_j)
        minus = np.abs(off - math.pi) <= cone_j
        s, j = np.nonzero(plus | minus)
        if s.size == 0:
            continue
        toward = plus[s, j]  # the sensor must lie on the -normal side
        jj = r0 + j
        rel = cones.xy[jj] - a[s]
        along = rel[:, 0] * t[s, 0] + rel[:, 1] * t[s, 1]
        side = rel[:, 1] * t[s, 0] - rel[:, 0] * t[s, 1]
        d = np.abs(side)
        ok = (along >= 0.0) & (along <= length[s]) & (d > 1e-9)
        ok &= np.where(toward, side < 0, side > 0)
        # the range must reach past every point of the line in the (whole) beam (of the
        # pairs left only: the same values elementwise, not the cosines of every reading)
        cos_beam = np.cos(np.minimum(cones.half_beam[jj], 0.5 * math.pi - 1e-9))
        ok &= cones.range_m[jj] * cos_beam > d + margin * cos_beam
        segs.append(s[ok])
        reads.append(jj[ok])
        alongs.append(along[ok])
    if not segs:
        return empty
    return (np.concatenate(segs).astype(np.intp), np.concatenate(reads).astype(np.intp),
            np.concatenate(alongs))  # fmt: skip


def distinct_viewpoints(viewpoint: npt.ArrayLike) -> int:
    """How many distinct viewpoints a set of readings' viewpoint ids holds.

    >>> distinct_viewpoints([3, 3, 5])
    2
    """
    return int(np.unique(np.asarray(viewpoint)).size)
