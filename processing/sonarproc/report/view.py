"""What a figure shows, in world metres: the view box, and geometry cut to it.

Every polyline a figure draws (truth, fit, surfaces, robot path) goes through
:func:`clip_polyline` first. A fit sampled over the truth's span may leave the map by
kilometres or overflow (a polynomial of order 9 extrapolated); drawn as is, such a curve
costs memory in proportion to its length in pixels. Cut to the view box, it costs no more
than a curve inside the map. Maps are reduced by :func:`block_max` to at most
:data:`MAX_DISPLAY` pixels a side before drawing, which loses no set cell.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.fit import Fit, FitFailure

__all__ = [
    "MAX_DISPLAY",
    "VIEW_MARGIN",
    "block_max",
    "broken_at_jumps",
    "clip_polyline",
    "fit_curve",
    "view_box",
]

#: Largest side (pixels) of a map image handed to matplotlib.
MAX_DISPLAY = 1000
#: The view box is the map's extent grown by this fraction of its larger side, so a line
#: leaving the map is drawn to the axes' edge (matplotlib cuts it there) and no further.
VIEW_MARGIN = 0.05

FloatArray = npt.NDArray[np.float64]
Box = tuple[float, float, float, float]


def block_max(a: npt.NDArray[np.generic], limit: int = MAX_DISPLAY) -> npt.NDArray[np.generic]:
    """Reduce a 2-D map by block maximum so neither side exceeds ``limit``.

    Examples
    --------
    >>> block_max(np.arange(16).reshape(4, 4), limit=2).tolist()
    [[5, 7], [13, 15]]
    """
    f = int(np.ceil(max(a.shape) / limit))
    if f <= 1:
        return a
    ny, nx = a.shape
    py, px = (-ny) % f, (-nx) % f
    if py or px:
        a = np.pad(a, ((0, py), (0, px)))
    # the f*f strided views of the blocks' cells, folded by maximum: about 4x faster than
    # a max over the two short axes of a (ny/f, f, nx/f, f) view on a 2000 x 2000 map
    out = a[::f, ::f].copy()
    for i in range(f):
        for j in range(f):
            if i or j:
                np.maximum(out, a[i::f, j::f], out=out)
    return out


def view_box(extent: Box, margin: float = VIEW_MARGIN) -> Box:
    """``extent`` (x0, x1, y0, y1) grown by ``margin`` times its larger side.

    >>> view_box((0.0, 2.0, 0.0, 1.0), 0.05)
    (-0.1, 2.1, -0.1, 1.1)
    """
    x0, x1, y0, y1 = extent
    pad = margin * max(x1 - x0, y1 - y0, 1e-9)
    return (x0 - pad, x1 + pad, y0 - pad, y1 + pad)


def broken_at_jumps(xy: FloatArray, factor: float = 8.0) -> FloatArray:
    """``xy`` with a NaN row wherever a step is ``factor`` times the median step.

    A truth profile of several walls is one polyline; drawn as is, it joins the walls.

    Examples
    --------
    >>> broken_at_jumps(np.array([[0.0, 0], [1, 0], [2, 0], [50, 0], [51, 0]]))[3].tolist()
    [nan, nan]
    """
    if xy.shape[0] < 3:
        return xy
    step = np.hypot(*np.diff(xy, axis=0).T)
    jumps = np.flatnonzero(step > factor * max(float(np.nanmedian(step)), 1e-12))
    if jumps.size == 0:
        return xy
    return np.insert(xy, jumps + 1, np.nan, axis=0)


def clip_polyline(xy: npt.ArrayLike, box: Box) -> FloatArray:
    """The parts of polyline ``xy`` inside ``box`` (x0, x1, y0, y1), NaN rows between parts.

    Each segment is cut to the box (Liang–Barsky); segments wholly outside, and points
    that are not finite (a NaN row breaks a polyline, an overflowed fit gives ±inf), are
    dropped. Consecutive inside segments stay one polyline. The result never has more
    than about twice the input's rows, and every finite value lies within ``box``.

    Examples
    --------
    >>> xy = np.array([[-1.0, 0.5], [0.5, 0.5], [2.0, 0.5]])
    >>> clip_polyline(xy, (0.0, 1.0, 0.0, 1.0)).tolist()
    [[0.0, 0.5], [0.5, 0.5], [1.0, 0.5]]
    >>> far = clip_polyline(np.array([[0.5, 0.5], [0.5, 1e300], [0.6, 0.5]]), (0, 1, 0, 1))
    >>> bool(np.nanmax(far) <= 1.0), far[:2].tolist()
    (True, [[0.5, 0.5], [0.5, 1.0]])
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if p.shape[0] < 2:
        inside = np.all(np.isfinite(p), axis=1) & _inside(p, box)
        return p[inside]
    a, b = p[:-1], p[1:]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        d = b - a
        ok = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
        ok &= np.all(np.isfinite(d), axis=1)
        t0 = np.zeros(len(a))
        t1 = np.ones(len(a))
        x0, x1, y0, y1 = box
        for q, r in ((-d[:, 0], a[:, 0] - x0), (d[:, 0], x1 - a[:, 0]),
                     (-d[:, 1], a[:, 1] - y0), (d[:, 1], y1 - a[:, 1])):  # fmt: skip
            parallel = q == 0
            ok &= ~(parallel & (r < 0))  # parallel to this edge and outside it
            t = np.where(parallel, 0.0, r / np.where(parallel, 1.0, q))
            t0 = np.where(~parallel & (q < 0), np.maximum(t0, t), t0)
            t1 = np.where(~parallel & (q > 0), np.minimum(t1, t), t1)
        ok &= t0 <= t1
        # from the nearer end, so a point 1e12 m away does not cost the cut its precision
        start = np.where((t0 < 0.5)[:, None], a + t0[:, None] * d, b - (1 - t0)[:, None] * d)
        end = np.where((t1 < 0.5)[:, None], a + t1[:, None] * d, b - (1 - t1)[:, None] * d)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return np.zeros((0, 2))
    # a segment continues the previous kept one when they meet uncut at a shared point
    joined = np.zeros(idx.size, dtype=bool)
    joined[1:] = (np.diff(idx) == 1) & (t1[idx[:-1]] == 1.0) & (t0[idx[1:]] == 0.0)
    rows = np.stack((np.full((idx.size, 2), np.nan), start[idx], end[idx]), axis=1)
    keep = np.column_stack((~joined, ~joined, np.ones(idx.size, dtype=bool)))
    keep[0, 0] = False  # no break before the first part
    res = rows[keep]
    return np.clip(res, (x0, y0), (x1, y1))  # rounding of a + t d can step out by an ulp


def _inside(p: FloatArray, box: Box) -> npt.NDArray[np.bool_]:
    x0, x1, y0, y1 = box
    return (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)


def fit_curve(fit: Fit, truth: FloatArray | None, step: float) -> FloatArray:
    """The fit sampled every ``step`` over its points *and* the whole truth span.

    E1 and E2 are measured over the truth's columns, so a curve drawn only over the
    points would hide the error where the fit leaves them (extrapolation). At most
    20 000 samples; cut it to the view with :func:`clip_polyline` before drawing.

    Examples
    --------
    >>> from sonarproc.fit import PolyFit
    >>> line = PolyFit(order=1, coef=np.array([0.0, 1.0]), domain=(0.0, 1.0))
    >>> c = fit_curve(line, np.array([[-1.0, 0.0], [2.0, 0.0]]), 0.5)
    >>> float(c[0, 0]), float(c[-1, 0])
    (-1.0, 2.0)
    """
    if isinstance(fit, FitFailure):
        return np.zeros((0, 2))
    if fit.kind == "polar" or truth is None or not truth.size:
        return fit.sample(step)
    lo = min(float(fit.domain[0]), float(np.nanmin(truth[:, 0])))
    hi = max(float(fit.domain[1]), float(np.nanmax(truth[:, 0])))
    n = min(int(np.floor((hi - lo) / step)) + 1, 20_000)
    x = np.linspace(lo, hi, max(n, 2))
    with np.errstate(over="ignore", invalid="ignore"):
        return np.column_stack((x, fit(x)))
