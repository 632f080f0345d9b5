"""Pieces of one straight wall, joined again.

The ridge of a count map is cut wherever other ridges cross it (arcs from a corner, the
tails of a bundle), so one wall often comes out as several collinear line segments with
gaps between them. Each piece then has only part of the wall's echoes, and a sparse
log (a robot passing a wall once) may leave every piece below the echoes a surface needs.
Line segments that are nearly parallel (:data:`MERGE_ANGLE_RAD`) and lie on one line are
one surface: their cells are pooled and fitted again. Two walls of a corridor (far more
than :data:`MERGE_OFFSET_M` apart) stay separate.

*On one line* means within the pieces' fit uncertainty: both ends of one piece lie within
``3 hypot(sigma(u), sigma_end) + cell`` of the other's line (never more than
:data:`MERGE_OFFSET_M`), where ``sigma(u) = rms sqrt(1/N + (u - u_mean)^2 / S_uu)`` is the
standard error of a total least squares line through ``N`` cells with residual ``rms`` at
a distance ``u`` along it, and ``sigma_end`` the same of the end's own piece at that end
(an end is a point of that piece's fitted line, as uncertain as the line is there: two
pieces of one wall differ by both errors), the cell: the ridge's own quantisation, one
cell either way. One of the two lines passing
so is enough: a short piece of a sparse log (a few echo points over a metre) has a line
whose direction is uncertain by a degree or two, which puts a long piece's far end
beyond :data:`MERGE_OFFSET_M` of it although the long piece's own line, which is well
determined, passes through the short piece.

The gap between them: given the readings (:class:`~sonarproc.surfaces.freespace.FreeCones`),
the pieces are joined however long the gap, unless readings from
:data:`~sonarproc.surfaces.freespace.MIN_FREE_POSES` distinct viewpoints saw through it
(:func:`~sonarproc.surfaces.freespace.free_feet` on the gap): a doorway they looked through
stays open, a stretch of wall nobody faced (behind a pillar, or passed too fast for a
sparse log) is closed. Without readings, only gaps shorter than :data:`MERGE_GAP_M` are
bridged.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.extraction.graphs import components
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit
from sonarproc.surfaces.freespace import MIN_FREE_POSES, FreeCones, free_feet

__all__ = [
    "MERGE_ANGLE_RAD",
    "MERGE_GAP_M",
    "MERGE_OFFSET_M",
    "collinear_groups",
    "merge_collinear",
    "pool_cells",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Largest angle between two pieces of one wall (rad).
MERGE_ANGLE_RAD = np.deg2rad(5.0)
#: Largest distance (m) of one piece's ends from the other's line, whatever the fits'
#: uncertainty (the ridge of a wall wanders by less).
MERGE_OFFSET_M = 0.05
#: Longest gap (m) between two pieces of one wall, along it, when no readings say whether
#: the gap is open.
MERGE_GAP_M = 0.30
#: Standard errors of a piece's line within which the other piece must lie.
MERGE_SIGMAS = 3.0


def _frames(
    fits: list[SurfaceFit], cells: list[SurfaceCells]
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Each piece's line (a point, a unit direction), its ends and its residual (m): a
    line's own; for another model, the total least squares line through its cells, and
    its ends projected onto that line (a piece taken as straight is that line: a curve's
    ends, which bend off it, would put it off its neighbour's line)."""
    m = len(fits)
    c, t, rms = np.zeros((m, 2)), np.zeros((m, 2)), np.zeros(m)
    ends = np.stack([f.polyline[[0, -1]] for f in fits]) if fits else np.zeros((0, 2, 2))
    for k, (f, p) in enumerate(zip(fits, cells, strict=True)):
        if f.model == "line":
            c[k], t[k], rms[k] = f.params["point"], f.params["direction"], f.rms_m
        else:
            c[k], t[k], rms[k] = _tls(p)
            ends[k] = c[k] + np.outer((ends[k] - c[k]) @ t[k], t[k])
    return c, t, ends, rms


def _tls(p: SurfaceCells) -> tuple[FloatArray, FloatArray, float]:
    """Centroid, direction and RMS residual of the total least squares line of cells."""
    xy = np.stack((p.x, p.y), axis=1)
    mean = xy.mean(axis=0)
    _, sv, vt = np.linalg.svd(xy - mean, full_matrices=False)
    rest = float(sv[1]) if sv.size > 1 else 0.0
    return mean, vt[0], rest / np.sqrt(max(xy.shape[0], 1))


def collinear_groups(
    fits: list[SurfaceFit],
    cells: list[SurfaceCells],
    *,
    cell: float,
    cones: FreeCones | None = None,
    margin: float = 0.0,
    straight_rms: float | None = None,
) -> list[list[int]]:
    """The groups of pieces of one wall: indices into ``fits``, two or more per group.

    Parameters as :func:`merge_collinear`; ``straight_rms`` (m), when given, also takes
    open surfaces of other models whose cells lie within this RMS of a straight line.
    """

    def straight(f: SurfaceFit, p: SurfaceCells) -> bool:
        if f.closed or len(f.polyline) < 2 or p.size < 2:
            return False
        return f.model == "line" or (straight_rms is not None and _tls(p)[2] <= straight_rms)

    line = [i for i, (f, p) in enumerate(zip(fits, cells, strict=True)) if straight(f, p)]
    if len(line) < 2:
        return []
    c, t, ends, rms = _frames([fits[i] for i in line], [cells[i] for i in line])
    spread = _spread([cells[k] for k in line], c, t, rms)
    # only nearly parallel pairs are tested further (a few per cent of all pairs)
    i, j = np.nonzero(np.triu(np.abs(t @ t.T) >= np.cos(MERGE_ANGLE_RAD), 1))
    # the better determined line decides: a short piece's own line, extrapolated over a
    # long one, is too uncertain to say where the wall runs there
    ok = _on_line(c[i], t[i], ends[j], spread[i], cell, _end_sigma(c[j], t[j], ends[j], spread[j]))
    ok |= _on_line(c[j], t[j], ends[i], spread[j], cell, _end_sigma(c[i], t[i], ends[i], spread[i]))
    i, j = i[ok], j[ok]
    gap0, gap1 = _gaps(c[i], t[i], ends[i], ends[j])
    if cones is None:
        ok = np.hypot(*(gap1 - gap0).T) <= MERGE_GAP_M
    else:
        ok = _closed(gap0, gap1, cones, margin)
    i, j = i[ok], j[ok]
    if i.size == 0:
        return []
    _, label = components(len(line), i, j)
    groups: dict[int, list[int]] = {}
    for k, piece in enumerate(line):
        groups.setdefault(int(label[k]), []).append(piece)
    return [members for members in groups.values() if len(members) > 1]


def merge_collinear(
    fits: list[SurfaceFit],
    cells: list[SurfaceCells],
    *,
    cell: float,
    cones: FreeCones | None = None,
    margin: float = 0.0,
) -> tuple[list[SurfaceFit], list[SurfaceCells]]:
    """Join the line pieces of one wall (see the module notes); other surfaces pass through.

    Parameters
    ----------
    fits : list of SurfaceFit
        Fitted surfaces.
    cells : list of SurfaceCells
        Their cells (same order).
    cell : float
        Cell size (m).
    cones : FreeCones, optional
        The readings: a gap that readings saw through is not bridged (module notes).
        Without them, gaps up to :data:`MERGE_GAP_M` are.
    margin : float
        Range tolerance (m) of the free-space test (the pieces' distance from the true
        wall, a ridge's bias included).

    Returns
    -------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        The surfaces with every group of joined pieces replaced by one refitted surface.

    Examples
    --------
    Two pieces of the wall y = 1 with a 10 cm gap become one line 2 m long:

    >>> x1, x2 = np.arange(0.0, 0.95, 0.01), np.arange(1.05, 2.0, 0.01)
    >>> pieces = [SurfaceCells(x, 1 + 0 * x, x - x[0], 1 + 0 * x, False) for x in (x1, x2)]
    >>> fits = fit_surfaces(pieces, cell=0.01)
    >>> merged, _ = merge_collinear(fits, pieces, cell=0.01)
    >>> [(f.model, round(f.length_m, 2)) for f in merged]
    [('line', 1.99)]
    """
    found = collinear_groups(fits, cells, cell=cell, cones=cones, margin=margin)
    if not found:
        return list(fits), list(cells)
    out_fits: list[SurfaceFit] = []
    out_cells: list[SurfaceCells] = []
    groups = dict(enumerate(found))
    group_of = {i: g for g, members in groups.items() for i in members}
    pooled = {g: pool_cells([cells[m] for m in members]) for g, members in groups.items()}
    refit = dict(zip(pooled, fit_surfaces(list(pooled.values()), cell=cell), strict=True))
    emitted: set[int] = set()
    for k, (f, cc) in enumerate(zip(fits, cells, strict=True)):
        g = group_of.get(k)
        if g is None:
            out_fits.append(f)
            out_cells.append(cc)
            continue
        if g in emitted:  # the group stands where its first piece stood
            continue
        emitted.add(g)
        new = refit[g]
        if isinstance(new, SurfaceFailure):  # keep the pieces as they were
            out_fits += [fits[m] for m in groups[g]]
            out_cells += [cells[m] for m in groups[g]]
        else:
            out_fits.append(new)
            out_cells.append(pooled[g])
    return out_fits, out_cells


def _spread(cells: list[SurfaceCells], c: FloatArray, t: FloatArray, rms: FloatArray) -> FloatArray:
    """Per line: its residual, cell count, mean position along it and ``S_uu`` (rows)."""
    out = np.zeros((len(cells), 4))
    for k, p in enumerate(cells):
        u = (p.x - c[k, 0]) * t[k, 0] + (p.y - c[k, 1]) * t[k, 1]
        n = max(u.size, 1)
        mean = float(u.mean()) if u.size else 0.0
        out[k] = (rms[k], n, mean, max(float(((u - mean) ** 2).sum()), 1e-12))
    return out


def _sigma(u: FloatArray, spread: FloatArray) -> FloatArray:
    """Standard error across a line at positions ``u`` along it (rows of ``_spread``)."""
    rms, n, mean, suu = (spread[:, k, None] for k in range(4))
    return np.asarray(rms * np.sqrt(1.0 / n + (u - mean) ** 2 / suu))


def _end_sigma(c: FloatArray, t: FloatArray, ends: FloatArray, spread: FloatArray) -> FloatArray:
    """Standard error of each piece's own line at its two ends (pair, end)."""
    return _sigma(np.einsum("pex,px->pe", ends - c[:, None, :], t), spread)


def _on_line(
    c: FloatArray, t: FloatArray, other: FloatArray, spread: FloatArray, cell: float,
    other_sigma: FloatArray,
) -> BoolArray:  # fmt: skip
    """Whether each ``other`` segment lies on the line ``c + u t``: both its ends within the
    line's uncertainty there, combined with the uncertainty of the ends themselves (each
    is an end of the other piece's own fitted line; module notes)."""
    normal = np.stack((-t[:, 1], t[:, 0]), axis=1)
    rel = other - c[:, None, :]  # (pair, end, xy)
    offset = np.abs(np.einsum("pex,px->pe", rel, normal))
    along = np.einsum("pex,px->pe", rel, t)
    sigma = np.hypot(_sigma(along, spread), other_sigma)
    tol = np.minimum(MERGE_SIGMAS * sigma + cell, MERGE_OFFSET_M)
    return np.asarray(np.all(offset <= tol, axis=1))


def _gaps(
    c: FloatArray, t: FloatArray, own: FloatArray, other: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The gap between each pair of pieces, on the first one's line (ends equal when they
    overlap)."""
    along = np.einsum("pex,px->pe", other - c[:, None, :], t)
    mine = np.einsum("pex,px->pe", own - c[:, None, :], t)
    after = along.min(axis=1) - mine.max(axis=1)  # the other piece beyond this one's end
    before = mine.min(axis=1) - along.max(axis=1)
    u0 = np.where(after >= before, mine.max(axis=1), along.max(axis=1))
    u1 = np.where(after >= before, along.min(axis=1), mine.min(axis=1))
    u1 = np.maximum(u1, u0)
    return c + t * u0[:, None], c + t * u1[:, None]


def _closed(gap0: FloatArray, gap1: FloatArray, cones: FreeCones, margin: float) -> BoolArray:
    """Whether fewer than MIN_FREE_POSES viewpoints saw through each gap ``gap0 -> gap1``."""
    real = np.flatnonzero(np.hypot(*(gap1 - gap0).T) > 0)
    views = np.zeros(gap0.shape[0], dtype=np.int64)
    if real.size:
        seg, read, _ = free_feet(gap0[real], gap1[real], cones, margin=margin)
        pairs = np.unique(np.stack((real[seg], cones.viewpoint[read]), axis=1), axis=0)
        views = np.bincount(pairs[:, 0], minlength=gap0.shape[0]) if pairs.size else views
    return np.asarray(views < MIN_FREE_POSES)


def pool_cells(pieces: list[SurfaceCells]) -> SurfaceCells:
    """The pieces' cells as one surface, ordered along their common line."""
    x = np.concatenate([p.x for p in pieces])
    y = np.concatenate([p.y for p in pieces])
    w = np.concatenate([p.weight for p in pieces])
    _, t, _ = _tls(SurfaceCells(x, y, np.zeros_like(x), w, False))
    u = x * t[0] + y * t[1]
    order = np.argsort(u, kind="stable")
    u = u[order]
    return SurfaceCells(x[order], y[order], u - u[0], w[order], False)
