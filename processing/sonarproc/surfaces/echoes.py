"""Where each reading reflected: surfaces refitted through their specular echo points.

A sonar's range arc is tangent to the surface that reflected it, at the one point where
the surface's normal points at the sensor, and lies on the sensor's side of the surface
everywhere else. Where many arcs touch a surface at one point (the robot driving towards
a wall, or round a pillar) the crest of the arc counts therefore lies on the sensors'
side of the surface, and arcs crossing at a shallow angle (the tails of a bundle) make
ridges where there is no surface at all. The ridge gives a first estimate of each
surface; this module replaces it by the surface through the readings' echo points:

* the *foot* of a reading on a surface is the surface point nearest its sensor (the
  perpendicular from the sensor, so the surface normal there points at the sensor);
* a reading *echoes* from a surface when its foot lies inside the surface (not at an
  end), inside the sensor's beam, and the foot's distance is within ``tol`` of the
  measured range; a reading echoing from several surfaces is given to the nearest match
  (a first echo comes from one surface);
* its *echo point* is the point at the measured range along the direction of the foot.

The direction of the foot is the surface normal even when the estimate is displaced
along it, so the echo points lie on the true surface: the refit removes the bias. Each
surface is refitted (:func:`~sonarproc.surfaces.models.fit_surface`, same criterion)
through its echo points, twice, with the tolerances of :data:`ROUNDS_M`; a surface that
fewer than :data:`MIN_ECHOES` readings echo from, or whose echo points span less than
:data:`MIN_SPREAD_M`, is dropped (no reading reflected there, or only at one point).
After every round a refitted line or open arc is stretched over the ridge cells within
that round's tolerance of it (the ridge sees the surface further than the perpendiculars
reach; and a fit through echo points ends at the outermost ones, whose feet would fall on
its ends in the next round), by at most :data:`MAX_STRETCH_M` at each end. Before the
first round the pieces of one wall are joined (:mod:`sonarproc.surfaces.merge`); after
the last, of two surfaces that contradict each other the weaker goes
(:mod:`sonarproc.surfaces.occlusion`).

Bistatic readings are taken at the midpoint of transmitter and receiver with the
ellipse's half minor axis as the range (exact for a surface parallel to the baseline).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from sonarproc.surfaces.batchfit import fit_surfaces
from sonarproc.surfaces.extract import SurfaceCells
from sonarproc.surfaces.merge import merge_collinear
from sonarproc.surfaces.models import SurfaceFailure, SurfaceFit
from sonarproc.surfaces.occlusion import contradicted
from sonarproc.surfaces.polylines import resample

__all__ = ["MIN_ECHOES", "ROUNDS_M", "EchoGeometry", "echo_points", "refine_fits"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Range tolerances (m) of the refinement rounds: the first covers the ridge's bias.
ROUNDS_M = (0.08, 0.03)
#: Fewest echoing readings a surface needs to be kept.
MIN_ECHOES = 5
#: Shortest stretch (m) its echo points must cover: echoes all at one point (a corner's
#: double reflections, arriving at the corner's distance) say nothing of a direction.
MIN_SPREAD_M = 0.10
#: A refitted line or arc is stretched over nearby ridge cells by at most this (m) at
#: each end.
MAX_STRETCH_M = 0.25


@dataclass(frozen=True)
class EchoGeometry:
    """Each reading as one sensor: position, heading, half beam width, range (SI)."""

    xy: FloatArray
    heading: FloatArray
    half_beam: FloatArray
    range_m: FloatArray

    @classmethod
    def from_beams(
        cls,
        tx_xy: npt.ArrayLike,
        tx_heading: npt.ArrayLike,
        rx_xy: npt.ArrayLike,
        rx_heading: npt.ArrayLike,
        path: npt.ArrayLike,
        *,
        tx_half_beamwidth: npt.ArrayLike,
        rx_half_beamwidth: npt.ArrayLike,
    ) -> EchoGeometry:
        """From transmitter and receiver poses and path lengths (see the module notes).

        Examples
        --------
        >>> g = EchoGeometry.from_beams([[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [2.0],
        ...                             tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)
        >>> g.range_m.tolist(), g.xy.tolist()
        ([1.0], [[0.0, 0.0]])
        """
        t = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
        r = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
        n = t.shape[0]
        path_m = np.broadcast_to(np.asarray(path, dtype=np.float64), (n,))
        half_d = 0.5 * np.hypot(*(r - t).T)
        rng = np.sqrt(np.maximum((0.5 * path_m) ** 2 - half_d**2, 0.0))
        th = np.broadcast_to(np.asarray(tx_heading, dtype=np.float64), (n,))
        rh = np.broadcast_to(np.asarray(rx_heading, dtype=np.float64), (n,))
        heading = np.arctan2(np.sin(th) + np.sin(rh), np.cos(th) + np.cos(rh))
        tb = np.broadcast_to(np.asarray(tx_half_beamwidth, dtype=np.float64), (n,))
        rb = np.broadcast_to(np.asarray(rx_half_beamwidth, dtype=np.float64), (n,))
        ok = np.isfinite(rng) & np.all(np.isfinite(t), axis=1) & np.all(np.isfinite(r), axis=1)
        return cls(0.5 * (t + r)[ok], heading[ok], np.minimum(tb, rb)[ok], rng[ok])

    @property
    def size(self) -> int:
        """Number of readings."""
        return int(self.range_m.size)


def _feet(
    q: FloatArray, poly: FloatArray, closed: bool
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """Nearest point of a finely sampled polyline to each of ``q``.

    Returns the distance, the foot, its arc length along the polyline and whether it is
    inside (not at an open end).
    """
    seg = np.hypot(*np.diff(poly, axis=0).T)
    s_vert = np.concatenate(([0.0], np.cumsum(seg)))
    _, k = cKDTree(poly).query(q)
    k = np.asarray(k, dtype=np.intp)
    best_d = np.hypot(*(q - poly[k]).T)
    best_f = poly[k].copy()
    best_s = s_vert[k].copy()
    last = poly.shape[0] - 1
    for side in (-1, 1):
        j = k + side
        ok = (j >= 0) & (j <= last)
        a, b = poly[k[ok]], poly[j[ok]]
        ab = b - a
        den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
        t = np.clip(np.einsum("ij,ij->i", q[ok] - a, ab) / den, 0.0, 1.0)
        foot = a + ab * t[:, None]
        d = np.hypot(*(q[ok] - foot).T)
        better = d < best_d[ok]
        idx = np.flatnonzero(ok)[better]
        best_d[idx] = d[better]
        best_f[idx] = foot[better]
        best_s[idx] = (s_vert[k[ok]] + t * (s_vert[j[ok]] - s_vert[k[ok]]))[better]
    if closed:
        inside = np.ones(q.shape[0], dtype=bool)
    else:
        step = float(np.median(seg)) if seg.size else 0.0
        inside = (best_s > 0.5 * step) & (best_s < s_vert[-1] - 0.5 * step)
    return best_d, best_f, best_s, inside


def echo_points(
    polylines: list[FloatArray],
    closed: list[bool],
    echoes: EchoGeometry,
    *,
    tol: float,
) -> list[tuple[IntArray, FloatArray, FloatArray]]:
    """The readings that echo from each surface, their echo points and the feet's arc length.

    Parameters
    ----------
    polylines : list of ndarray, shape (K_i, 2)
        Surfaces sampled finely (every cell).
    closed : list of bool
        Whether each surface closes on itself.
    echoes : EchoGeometry
        The readings.
    tol : float
        Range tolerance (m).

    Returns
    -------
    list of (readings, points, s)
        Per surface: indices into ``echoes``, echo points ``(E, 2)`` and the arc length
        of each foot along the polyline (sorted by it).

    Examples
    --------
    A wall along y = 1 and a sensor below it looking up, range 1.02 m: the echo point is
    on the wall although the range is 2 cm long.

    >>> wall = np.column_stack((np.linspace(-1, 1, 201), np.ones(201)))
    >>> g = EchoGeometry(np.zeros((1, 2)), np.array([np.pi / 2]), np.array([0.2]),
    ...                  np.array([1.02]))
    >>> (idx, pts, s), = echo_points([wall], [False], g, tol=0.05)
    >>> idx.tolist(), np.round(pts, 3).tolist()
    ([0], [[0.0, 1.02]])
    """
    n, m = echoes.size, len(polylines)
    empty = (np.zeros(0, np.intp), np.zeros((0, 2)), np.zeros(0))
    polys = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in polylines]
    usable = np.array([p.shape[0] >= 2 for p in polys], dtype=bool)
    if n == 0 or not usable.any():
        return [empty for _ in range(m)]
    surf, read = _candidate_pairs(polys, usable, echoes, tol)
    straight = _straight(polys, usable)
    d = np.empty(surf.size)
    foot = np.empty((surf.size, 2))
    along = np.empty(surf.size)
    inside = np.empty(surf.size, dtype=bool)
    line = straight[surf]
    if line.any():
        d[line], foot[line], along[line], inside[line] = _feet_on_segments(
            echoes.xy[read[line]], polys, surf[line]
        )
    bounds = np.searchsorted(surf, np.arange(m + 1))
    for i in np.flatnonzero(usable & ~straight):
        sel = slice(bounds[i], bounds[i + 1])
        if bounds[i] < bounds[i + 1]:
            d[sel], foot[sel], along[sel], inside[sel] = _feet(
                echoes.xy[read[sel]], polys[i], bool(closed[i])
            )
    v = foot - echoes.xy[read]
    off = np.abs(
        (np.arctan2(v[:, 1], v[:, 0]) - echoes.heading[read] + math.pi) % (2 * math.pi) - math.pi
    )
    resid = np.abs(d - echoes.range_m[read])
    ok = inside & (off <= echoes.half_beam[read]) & (resid <= tol)
    surf, read, resid, foot, along = surf[ok], read[ok], resid[ok], foot[ok], along[ok]
    # A first echo comes from one surface: each reading goes to its best match (the
    # lowest residual; ties to the lower surface index, as the stable sort keeps them).
    order = np.lexsort((surf, resid, read))
    first = np.ones(order.size, dtype=bool)
    first[1:] = read[order][1:] != read[order][:-1]
    best = order[first]
    surf, read, foot, along = surf[best], read[best], foot[best], along[best]
    v = foot - echoes.xy[read]
    unit = v / np.maximum(np.hypot(*v.T), 1e-12)[:, None]
    pts = echoes.xy[read] + unit * echoes.range_m[read][:, None]
    o = np.lexsort((read, along, surf))
    surf, read, pts, along = surf[o], read[o], pts[o], along[o]
    bounds = np.searchsorted(surf, np.arange(m + 1))
    return [
        (read[bounds[i] : bounds[i + 1]], pts[bounds[i] : bounds[i + 1]],
         along[bounds[i] : bounds[i + 1]])
        for i in range(m)
    ]  # fmt: skip


def _candidate_pairs(
    polys: list[FloatArray], usable: npt.NDArray[np.bool_], echoes: EchoGeometry, tol: float
) -> tuple[IntArray, IntArray]:
    """(surface, reading) pairs that may echo, grouped by surface (cheap tests only)."""
    # Every point of a reading's arc band lies within ``reach`` of the arc's midpoint, so
    # a surface (a box of half-diagonal h round c) can only echo readings whose midpoint
    # is within h + reach of c: one ball query per surface instead of a test of every
    # reading (rooms logged for an hour hold 10^5 readings).
    half = np.minimum(echoes.half_beam, math.pi)
    reach = 2.0 * echoes.range_m * np.sin(0.5 * half) + tol
    mid = echoes.xy + echoes.range_m[:, None] * np.stack(
        (np.cos(echoes.heading), np.sin(echoes.heading)), axis=1
    )
    idx = np.flatnonzero(usable)
    lo = np.array([polys[i].min(axis=0) for i in idx]).reshape(-1, 2)
    hi = np.array([polys[i].max(axis=0) for i in idx]).reshape(-1, 2)
    c, h = 0.5 * (lo + hi), 0.5 * np.hypot(*(hi - lo).T)
    k, read = _ball_pairs(c, h, mid, reach)
    # The surface lies between |s - c| - h and |s - c| + h from a sensor s and within
    # asin(h / |s - c|) of the direction of c: the foot can only be in range and in the
    # beam if those intervals meet (cheap; most readings of a big room fail it).
    to_c = c[k] - echoes.xy[read]
    dist = np.sqrt(np.einsum("ij,ij->i", to_c, to_c))
    keep = np.abs(dist - echoes.range_m[read]) <= h[k] + tol
    k, read, to_c, dist = k[keep], read[keep], to_c[keep], dist[keep]
    spread = np.arcsin(np.minimum(h[k] / np.maximum(dist, 1e-12), 1.0))
    off_c = np.abs(
        (np.arctan2(to_c[:, 1], to_c[:, 0]) - echoes.heading[read] + math.pi) % (2 * math.pi)
        - math.pi
    )
    keep = off_c <= echoes.half_beam[read] + spread
    surf, read = idx[k[keep]], read[keep]
    o = np.argsort(surf, kind="stable")
    return surf[o], read[o]


def _ball_pairs(
    c: FloatArray, h: FloatArray, mid: FloatArray, reach: FloatArray
) -> tuple[IntArray, IntArray]:
    """Pairs (surface k, reading j) with ``|mid_j - c_k| <= h_k + reach_j``.

    Surfaces and readings are split into classes of similar size (powers of two of ``h``
    and of ``reach``), so that each class pair is one radius search between two KD-trees
    with a radius close to the pairs' own (one radius for all would take every reading
    within the largest reach of every small surface).
    """

    def classes(v: FloatArray) -> IntArray:
        return np.floor(np.log2(np.maximum(v, 0.125) / 0.125)).astype(np.intp)

    hc, rc = classes(h), classes(reach)
    by_reach = [np.flatnonzero(rc == b) for b in np.unique(rc)]
    trees = [cKDTree(mid[rj]) for rj in by_reach]
    ks: list[IntArray] = []
    js: list[IntArray] = []
    for a in np.unique(hc):
        sk = np.flatnonzero(hc == a)
        tree_s = cKDTree(c[sk])
        for rj, tree_r in zip(by_reach, trees, strict=True):
            radius = float(h[sk].max() + reach[rj].max())
            got = tree_s.sparse_distance_matrix(tree_r, radius, output_type="ndarray")
            kk, jj = sk[got["i"]], rj[got["j"]]
            keep = got["v"] <= h[kk] + reach[jj]
            ks.append(kk[keep])
            js.append(jj[keep])
    return np.concatenate(ks), np.concatenate(js)


def _straight(polys: list[FloatArray], usable: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """Which polylines are straight (every vertex on the chord, to rounding)."""
    out = np.zeros(len(polys), dtype=bool)
    for i in np.flatnonzero(usable):
        p = polys[i]
        chord = p[-1] - p[0]
        span = float(np.hypot(*chord))
        if span > 0:
            dev = np.abs((p[:, 0] - p[0, 0]) * chord[1] - (p[:, 1] - p[0, 1]) * chord[0])
            out[i] = dev.max() <= 1e-9 * span * max(span, 1.0)
    return out


def _median_steps(polys: list[FloatArray]) -> FloatArray:
    """The median segment length of each polyline (all at once: one sort)."""
    seg = np.hypot(*np.diff(np.concatenate(polys), axis=0).T)
    sizes = np.array([len(p) for p in polys])
    last = np.cumsum(sizes) - 1
    mask = np.ones(seg.size, dtype=bool)
    mask[last[:-1]] = False  # the gaps between one polyline and the next
    n = sizes - 1
    owner = np.repeat(np.arange(len(polys)), n)
    seg = seg[mask]
    order = np.lexsort((seg, owner))
    ranked = seg[order]
    first = np.cumsum(n) - n
    lo = ranked[first + (n - 1) // 2]
    hi = ranked[first + n // 2]
    return np.asarray(0.5 * (lo + hi), dtype=np.float64)


def _feet_on_segments(
    q: FloatArray, polys: list[FloatArray], surf: IntArray
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """:func:`_feet` of each point ``q[k]`` on the straight polyline ``polys[surf[k]]``."""
    ids = np.unique(surf)
    a = np.array([polys[i][0] for i in ids])
    b = np.array([polys[i][-1] for i in ids])
    # a vertex this close to an open end counts as the end (as for curved polylines)
    step = _median_steps([polys[i] for i in ids])
    k = np.searchsorted(ids, surf)
    ab = (b - a)[k]
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", q - a[k], ab) / length2, 0.0, 1.0)
    foot = a[k] + ab * t[:, None]
    d = np.hypot(*(q - foot).T)
    length = np.sqrt(length2)
    along = t * length
    inside = (along > 0.5 * step[k]) & (along < length - 0.5 * step[k])
    return d, foot, along, inside


def _extend(fit: SurfaceFit, cells: SurfaceCells, tol: float, cell: float) -> SurfaceFit:
    """Stretch a refitted line or open arc over the ridge cells within ``tol`` of it."""
    if fit.closed or cells.size == 0:
        return fit
    x, y = cells.x, cells.y
    if fit.model == "line":
        c, t = np.asarray(fit.params["point"]), np.asarray(fit.params["direction"])
        near = np.abs((x - c[0]) * -t[1] + (y - c[1]) * t[0]) <= tol
        u0 = (fit.polyline - c) @ t
        u = (np.stack((x, y), 1)[near] - c) @ t
        u = np.clip(np.concatenate((u0, u)), u0.min() - MAX_STRETCH_M, u0.max() + MAX_STRETCH_M)
        poly = resample(np.stack((c + t * u.min(), c + t * u.max())), cell)
        if (fit.polyline[-1] - fit.polyline[0]) @ t < 0:
            poly = poly[::-1]
    elif fit.model == "arc":
        cx, cy = fit.params["centre"]
        r = float(fit.params["radius"])
        near = np.abs(np.hypot(x - cx, y - cy) - r) <= tol
        start, sweep = float(fit.params["start_rad"]), float(fit.params["sweep_rad"])
        mid = start + 0.5 * sweep
        ang = mid + (np.arctan2(y[near] - cy, x[near] - cx) - mid + math.pi) % (2 * math.pi)
        ang -= math.pi
        ends = np.array([start, start + sweep])
        lo, hi = float(ends.min()), float(ends.max())
        if ang.size:
            reach = MAX_STRETCH_M / r
            lo = max(min(lo, float(ang.min())), lo - reach)
            hi = min(max(hi, float(ang.max())), hi + reach)
        if hi - lo >= 2 * math.pi:
            return fit
        k = max(2, math.ceil((hi - lo) * r / cell) + 1)
        phi = np.linspace(lo, hi, k)
        poly = np.stack((cx + r * np.cos(phi), cy + r * np.sin(phi)), axis=1)
        if sweep < 0:
            poly = poly[::-1]
    else:
        return fit
    length = float(np.hypot(*np.diff(poly, axis=0).T).sum())
    return replace(fit, polyline=poly, length_m=length)


def refine_fits(
    fits: list[SurfaceFit],
    cells: list[SurfaceCells],
    echoes: EchoGeometry,
    *,
    cell: float,
    rounds: tuple[float, ...] = ROUNDS_M,
    min_echoes: int = MIN_ECHOES,
) -> tuple[list[SurfaceFit], list[SurfaceCells]]:
    """Refit surfaces through their readings' echo points (see the module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The surfaces fitted to the ridge cells.
    cells : list of SurfaceCells
        Their ridge cells (same order).
    echoes : EchoGeometry
        The readings.
    cell : float
        Cell size (m): the polylines' step and the fits' unit.
    rounds : tuple of float
        Range tolerance (m) of each round.
    min_echoes : int
        A surface with fewer echoing readings is dropped.

    Returns
    -------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        The refitted surfaces (longest first) and their echo points as cells.
    """
    # pieces of one wall cut apart on the ridge share its echoes: join them first
    cur, ridge = merge_collinear(list(fits), list(cells), cell=cell)
    pts_cells: list[SurfaceCells] = []
    pts_idx: list[IntArray] = []
    for tol in rounds:
        got = echo_points([f.polyline for f in cur], [f.closed for f in cur], echoes, tol=tol)
        nxt: list[SurfaceFit] = []
        nxt_ridge: list[SurfaceCells] = []
        pts_cells, pts_idx = [], []
        todo = [
            k
            for k, (idx, pts, _) in enumerate(got)
            if idx.size >= min_echoes and np.hypot(*np.ptp(pts, axis=0)) >= MIN_SPREAD_M
        ]
        sets = [
            SurfaceCells(got[k][1][:, 0], got[k][1][:, 1], got[k][2] - got[k][2][0],
                         np.ones(got[k][0].size), cur[k].closed)
            for k in todo
        ]  # fmt: skip
        for k, ec, new in zip(todo, sets, fit_surfaces(sets, cell=cell), strict=True):
            if isinstance(new, SurfaceFailure):
                continue
            # stretched over its ridge before the next round: a fit through echo points
            # ends at the outermost ones, whose feet would then fall on its ends
            nxt.append(_extend(replace(new, arcs=int(got[k][0].size)), ridge[k], tol, cell))
            nxt_ridge.append(ridge[k])
            pts_cells.append(ec)
            pts_idx.append(got[k][0])
        cur, ridge = nxt, nxt_ridge
    drop = set(
        contradicted(
            [f.polyline for f in cur],
            [echoes.xy[i] for i in pts_idx],
            [np.stack((c.x, c.y), axis=1) for c in pts_cells],
            cell=cell,
        )
    )
    out = [f for i, f in enumerate(cur) if i not in drop]
    pts_cells = [c for i, c in enumerate(pts_cells) if i not in drop]
    order = sorted(range(len(out)), key=lambda i: -out[i].length_m)
    return [out[i] for i in order], [pts_cells[i] for i in order]
