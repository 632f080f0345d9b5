"""Echo models on a map of polylines: the range each predicts for a sensor pose.

Every model is the nearest point of a mapped surface whose direction from the sensor lies
within a cone about the sensor's axis and whose *incidence* (the angle between the line of
sight and the surface's normal) is at most a limit; on a straight segment both conditions
cut the angle of the line of sight to an interval (:func:`segment_ranges`). A model with
corners also hears the concave right-angle corners inside its cone
(:func:`corner_ranges`). ``echo_models.py`` compares them on logs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Readings x segments per block (memory: a few arrays of this many float64).
BLOCK = 1 << 20


@dataclass(frozen=True)
class EchoModel:
    """An echo model: the nearest mapped point within ``cone`` of the sensor's axis whose
    incidence is at most ``incidence`` (both rad); ``cone`` None is the sensor's own half
    beam width. With ``corners``, also the nearest concave right-angle corner inside the
    cone that no surface hides (a right dihedral sends an echo back from any direction
    within its opening)."""

    name: str
    cone: float | None
    incidence: float
    corners: bool = False


def models() -> list[EchoModel]:
    """The models of the table: today's, the axis ray-cast, diffuse and wider beams.

    The diffuse cones bracket a Polaroid 600-series transducer's main lobe (half width
    about 12-15 degrees at -6 dB; 20-25 degrees to the first null); the incidence limits
    bracket the angles at which a rough wall's backscatter is still within the detector's
    range at a few metres (Kleeman & Kuc 1995: smooth walls answer within a few degrees of
    normal, rough ones far beyond); 90 degrees is no limit (Moravec & Elfes).
    """
    deg = np.radians
    out = [
        EchoModel("specular (today)", None, 0.0),
        EchoModel("axis ray-cast", 0.0, deg(89.9)),
        EchoModel("specular and corners", None, 0.0, corners=True),
    ]
    for cone in (10.0, 15.0, 25.0):
        for inc in (30.0, 50.0, 89.9):
            lim = "no incidence limit" if inc > 89 else f"incidence <= {inc:.0f}°"
            out.append(EchoModel(f"diffuse, cone {cone:.0f}°, {lim}", deg(cone), deg(inc)))
    for cone in (20.0, 25.0, 30.0, 40.0):
        out.append(EchoModel(f"specular, cone {cone:.0f}°", deg(cone), 0.0))
    return out


def segments_of(lines: list[FloatArray]) -> tuple[FloatArray, FloatArray]:
    """The segments (starts, ends: (S, 2) each) of polylines, zero-length ones left out."""
    a = [ln[:-1] for ln in lines if ln.shape[0] >= 2]
    b = [ln[1:] for ln in lines if ln.shape[0] >= 2]
    if not a:
        return np.zeros((0, 2)), np.zeros((0, 2))
    start, end = np.vstack(a), np.vstack(b)
    keep = np.hypot(*(end - start).T) > 0
    return start[keep], end[keep]


def segment_ranges(
    xy: FloatArray,
    heading: FloatArray,
    cone: FloatArray,
    incidence: float,
    start: FloatArray,
    end: FloatArray,
) -> FloatArray:
    """Range (m) from each sensor to the nearest point of the segments within its cone
    whose incidence is at most ``incidence``; inf where there is none.

    In a frame on a segment's line, with the sensor at distance ``d`` from it, a point of
    the line seen at angle ``alpha`` from the normal through the sensor lies at
    ``d / cos(alpha)`` and is met at incidence ``|alpha|``. The segment, the cone about
    the axis (at ``beta`` from that normal) and the incidence limit each allow an interval
    of ``alpha``; the nearest allowed point has the allowed ``alpha`` nearest 0.

    Parameters
    ----------
    xy : ndarray, (N, 2)
        Sensor positions (m).
    heading, cone : ndarray, (N,)
        Axis direction and cone half width (rad); a cone of 0 is the axis only.
    incidence : float
        Largest incidence (rad) below pi/2; 0 is the specular point only.
    start, end : ndarray, (S, 2)
        The segments' end points (m).

    Examples
    --------
    A wall 1 m ahead, the sensor turned 20 degrees off its normal: the axis meets it at
    1 / cos(20°); a 15-degree beam holds no specular point; a 25-degree beam does.

    >>> wall = (np.array([[-5.0, 1.0]]), np.array([[5.0, 1.0]]))
    >>> at = np.zeros((1, 2)), np.array([np.radians(110.0)])
    >>> [round(float(segment_ranges(*at, np.array([c]), i, *wall)[0]), 6)
    ...  for c, i in ((0.0, 1.5), (np.radians(15), 0.0), (np.radians(25), 0.0))]
    [1.064178, inf, 1.0]
    """
    n = xy.shape[0]
    best = np.full(n, np.inf)
    if n == 0 or start.shape[0] == 0:
        return best
    tang = end - start
    length = np.hypot(tang[:, 0], tang[:, 1])
    tang = tang / length[:, None]
    normal = np.column_stack((-tang[:, 1], tang[:, 0]))
    ax = np.column_stack((np.cos(heading), np.sin(heading)))
    rows = max(1, BLOCK // start.shape[0])
    for s in range(0, n, rows):
        rel = xy[s : s + rows, None, :] - start[None, :, :]
        w = np.einsum("nsk,sk->ns", rel, normal)
        u_foot = np.einsum("nsk,sk->ns", rel, tang)
        d = np.abs(w)
        # the direction from the sensor towards the line is -sign(w) * normal
        toward = -np.sign(w)
        along = ax[s : s + rows] @ tang.T
        across = (ax[s : s + rows] @ normal.T) * toward
        beta = np.arctan2(along, across)
        with np.errstate(divide="ignore", invalid="ignore"):
            lo_seg = np.arctan2(-u_foot, d)
            hi_seg = np.arctan2(length[None, :] - u_foot, d)
        c = cone[s : s + rows, None]
        lo = np.maximum.reduce([lo_seg, beta - c, np.full_like(beta, -incidence)])
        hi = np.minimum.reduce([hi_seg, beta + c, np.full_like(beta, incidence)])
        ok = (lo <= hi) & (d > 0)
        alpha = np.clip(0.0, lo, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            rng = np.where(ok, d / np.cos(alpha), np.inf)
        best[s : s + rows] = rng.min(axis=1)
    return best


#: Largest turn (rad) at a polyline vertex that samples a smooth curve: 1-cm samples
#: turn by less on any radius over 2 cm, 2-mm Douglas-Peucker chords on any over 7 cm. A
#: sharper turn is a corner of the surface, an edge, which diffracts a weak echo only
#: (``sonarsim.transducer``: 0.05 of a wall's, spreading as 1/r^3) and is no specular point.
VERTEX_TURN = np.radians(30.0)


def vertex_ranges(
    xy: FloatArray, heading: FloatArray, cone: FloatArray, lines: list[FloatArray]
) -> FloatArray:
    """Range to the nearest interior vertex of the polylines that is inside the cone,
    nearer than both its neighbours and turns by less than :data:`VERTEX_TURN` (a convex
    bend of a sampled curve: its specular point, where the perpendicular feet miss both
    segments); inf where none.

    Examples
    --------
    >>> bend = [np.array([[-1.0, 1.1], [0.0, 1.0], [1.0, 1.1]])]
    >>> float(vertex_ranges(np.zeros((1, 2)), np.array([np.pi / 2]), np.array([0.2]), bend)[0])
    1.0
    """
    pts = [ln[1:-1] for ln in lines if ln.shape[0] >= 3]
    if not pts:
        return np.full(xy.shape[0], np.inf)
    v = np.vstack(pts)
    prev = np.vstack([ln[:-2] for ln in lines if ln.shape[0] >= 3])
    nxt = np.vstack([ln[2:] for ln in lines if ln.shape[0] >= 3])
    a_in, a_out = v - prev, nxt - v
    turn = np.abs(np.angle(np.exp(1j * (np.arctan2(a_out[:, 1], a_out[:, 0])
                                        - np.arctan2(a_in[:, 1], a_in[:, 0])))))  # fmt: skip
    smooth = turn < VERTEX_TURN
    v, prev, nxt = v[smooth], prev[smooth], nxt[smooth]
    if v.shape[0] == 0:
        return np.full(xy.shape[0], np.inf)
    best = np.full(xy.shape[0], np.inf)
    rows = max(1, BLOCK // v.shape[0])
    for s in range(0, xy.shape[0], rows):
        rel = v[None, :, :] - xy[s : s + rows, None, :]
        local_min = (np.einsum("nvk,vk->nv", rel, prev - v) >= 0) & (
            np.einsum("nvk,vk->nv", rel, nxt - v) >= 0
        )
        off = np.angle(np.exp(1j * (np.arctan2(rel[..., 1], rel[..., 0])
                                    - heading[s : s + rows, None])))  # fmt: skip
        inside = np.abs(off) <= cone[s : s + rows, None]
        dist = np.hypot(rel[..., 0], rel[..., 1])
        best[s : s + rows] = np.where(local_min & inside, dist, np.inf).min(axis=1)
    return best


#: A polyline vertex is a right-angle corner when it turns by 90 degrees within this
#: (rad): a dihedral within about 15 degrees of square still returns most of its echo
#: towards the sensor (``sonarsim``'s ``corner_angle_tolerance_deg``).
CORNER_TOLERANCE = np.radians(15.0)


@dataclass(frozen=True)
class Corners:
    """Corner reflectors of a map: points (C, 2) and, for corners of a polyline, the
    directions (C, 2) of the segments into and out of them (NaN for reported corners,
    seen as concave from anywhere)."""

    xy: FloatArray
    d_in: FloatArray
    d_out: FloatArray


def polyline_corners(lines: list[FloatArray], reported: FloatArray | None = None) -> Corners:
    """The right-angle vertices of ``lines`` (:data:`CORNER_TOLERANCE`), and the corners a
    run reported (``reported``, (P, 2)).

    Examples
    --------
    >>> c = polyline_corners([np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [3.0, 2.0]])])
    >>> c.xy.tolist()
    [[2.0, 0.0]]
    """
    xy, d_in, d_out = [], [], []
    for ln in lines:
        if ln.shape[0] < 3:
            continue
        a, b = ln[1:-1] - ln[:-2], ln[2:] - ln[1:-1]
        turn = np.angle(np.exp(1j * (np.arctan2(b[:, 1], b[:, 0]) - np.arctan2(a[:, 1], a[:, 0]))))
        keep = np.abs(np.abs(turn) - np.pi / 2) <= CORNER_TOLERANCE
        xy.append(ln[1:-1][keep])
        d_in.append(a[keep])
        d_out.append(b[keep])
    if reported is not None and reported.size:
        xy.append(reported)
        d_in.append(np.full(reported.shape, np.nan))
        d_out.append(np.full(reported.shape, np.nan))
    if not xy:
        return Corners(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2)))
    return Corners(np.vstack(xy), np.vstack(d_in), np.vstack(d_out))


#: A segment crossing the line of sight to a corner within this of the corner (m) is one
#: of the corner's own walls meeting it (the 5 cm tolerance), not an obstacle.
CORNER_OWN = 0.05


def _hidden(xy: FloatArray, corner: FloatArray, start: FloatArray, end: FloatArray
            ) -> BoolArray:  # fmt: skip
    """Whether a segment crosses the line of sight from each ``xy`` to ``corner`` short of
    :data:`CORNER_OWN` before it."""
    out = np.zeros(xy.shape[0], dtype=bool)
    if start.shape[0] == 0:
        return out
    e = end - start
    for i in range(0, xy.shape[0], max(1, BLOCK // start.shape[0])):
        p = xy[i : i + max(1, BLOCK // start.shape[0])]
        d = corner[None, :] - p
        length = np.hypot(d[:, 0], d[:, 1])[:, None]
        den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
        rel = start[None, :, :] - p[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (rel[..., 0] * e[None, :, 1] - rel[..., 1] * e[None, :, 0]) / den
            u = (rel[..., 0] * d[:, None, 1] - rel[..., 1] * d[:, None, 0]) / den
        cross = (t > 0) & (t * length < length - CORNER_OWN) & (u >= 0) & (u <= 1)
        out[i : i + p.shape[0]] = cross.any(axis=1)
    return out


def corner_ranges(xy: FloatArray, heading: FloatArray, cone: FloatArray, corners: Corners,
                  lines: list[FloatArray] | None = None) -> FloatArray:  # fmt: skip
    """Range to the nearest corner inside each sensor's cone that is concave as seen from
    the sensor (the sensor lies on the side both segments turn towards) and that no
    segment of ``lines`` hides (:data:`CORNER_OWN`); inf where none.

    Examples
    --------
    The inside of the corner at (2, 0) of a wall along y = 0 turning up x = 2:

    >>> c = polyline_corners([np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]])])
    >>> [float(corner_ranges(np.array([[1.0, 1.0]]), np.array([h]), np.array([0.3]), c)[0])
    ...  for h in (-np.pi / 4, 3 * np.pi / 4)]
    [1.4142135623730951, inf]
    """
    n = xy.shape[0]
    if corners.xy.shape[0] == 0 or n == 0:
        return np.full(n, np.inf)
    rel = corners.xy[None, :, :] - xy[:, None, :]
    off = np.angle(np.exp(1j * (np.arctan2(rel[..., 1], rel[..., 0]) - heading[:, None])))
    inside = np.abs(off) <= cone[:, None]
    # the sensor's side of each segment's line (its cross product with the direction from
    # the corner to the sensor), against the side the polyline turns towards
    d_in, d_out = corners.d_in[None, :, :], corners.d_out[None, :, :]
    side_in = np.sign(d_in[..., 1] * rel[..., 0] - d_in[..., 0] * rel[..., 1])
    side_out = np.sign(d_out[..., 1] * rel[..., 0] - d_out[..., 0] * rel[..., 1])
    turn = np.sign(d_in[..., 0] * d_out[..., 1] - d_in[..., 1] * d_out[..., 0])
    concave = (side_in == turn) & (side_out == turn)
    concave |= np.isnan(corners.d_in[None, :, 0])
    seen = inside & concave
    if lines:
        start, end = segments_of(lines)
        for k in range(corners.xy.shape[0]):
            rows = np.flatnonzero(seen[:, k])
            seen[rows, k] = ~_hidden(xy[rows], corners.xy[k], start, end)
    dist = np.hypot(rel[..., 0], rel[..., 1])
    return np.where(seen, dist, np.inf).min(axis=1)


def predict(
    model: EchoModel,
    xy: FloatArray,
    heading: FloatArray,
    half: FloatArray,
    lines: list[FloatArray],
    reported: FloatArray | None = None,
) -> FloatArray:
    """Range (m) ``model`` predicts off ``lines`` (and the corners a run ``reported``,
    (P, 2), for a model with corners) for each sensor pose; inf where none.

    Examples
    --------
    A wall 2 m away, the sensor's axis 50 degrees off its normal: no specular point in a
    15-degree beam; the axis meets it at 2 / cos(50°); the nearest point in the beam lies
    35 degrees off the normal, at 2 / cos(35°):

    >>> wall = [np.array([[-9.0, 2.0], [9.0, 2.0]])]
    >>> xy, h, half = np.zeros((1, 2)), np.array([np.radians(40.0)]), np.radians([15.0])
    >>> [round(float(predict(EchoModel("", c, i), xy, h, half, wall)[0]), 4)
    ...  for c, i in ((None, 0.0), (0.0, 1.5), (np.radians(15.0), 1.5))]
    [inf, 3.1114, 2.4415]
    """
    cone = half if model.cone is None else np.full(heading.shape, model.cone)
    start, end = segments_of(lines)
    rng = segment_ranges(xy, heading, cone, model.incidence, start, end)
    if model.cone is None or model.cone > 0:
        rng = np.fmin(rng, vertex_ranges(xy, heading, cone, lines))
    if model.corners:
        found = polyline_corners(lines, reported)
        rng = np.fmin(rng, corner_ranges(xy, heading, cone, found, lines))
    return rng


#: Largest distance (m) of a simplified polyline from the original: far below the 5 cm a
#: reading must be explained within, so the figures are those of the full polylines.
SIMPLIFY = 0.002


def simplify(lines: list[FloatArray]) -> list[FloatArray]:
    """``lines`` with the vertices that lie within :data:`SIMPLIFY` of the rest removed
    (Douglas-Peucker): a run's polylines come at 1 cm spacing, most of them straight."""
    from skimage.measure import approximate_polygon

    return [np.asarray(approximate_polygon(ln, SIMPLIFY), dtype=np.float64) for ln in lines]


def axis_wall(
    xy: FloatArray, heading: FloatArray, start: FloatArray, end: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The first segment each sensor's axis meets: the sensor's distance from its line and
    the axis's incidence on it (rad); NaN where the axis meets none.

    Examples
    --------
    >>> d, inc = axis_wall(np.zeros((1, 2)), np.array([np.radians(60.0)]),
    ...                    np.array([[-9.0, 2.0]]), np.array([[9.0, 2.0]]))
    >>> round(float(d[0]), 9), round(float(np.degrees(inc[0])), 9)
    (2.0, 30.0)
    """
    n = xy.shape[0]
    dist, inc, best = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.inf)
    ax = np.column_stack((np.cos(heading), np.sin(heading)))
    for k in range(start.shape[0]):  # a few dozen walls
        e = end[k] - start[k]
        rel = start[k] - xy
        den = ax[:, 0] * e[1] - ax[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (rel[:, 0] * e[1] - rel[:, 1] * e[0]) / den
            s = (rel[:, 0] * ax[:, 1] - rel[:, 1] * ax[:, 0]) / den
        hit = (t > 0) & (s >= 0) & (s <= 1) & (t < best)
        normal = np.array([-e[1], e[0]]) / np.hypot(*e)
        cos_inc = np.abs(ax @ normal)
        best = np.where(hit, t, best)
        dist = np.where(hit, t * cos_inc, dist)
        inc = np.where(hit, np.arccos(np.clip(cos_inc, 0.0, 1.0)), inc)
    return dist, inc
