"""Pieces of one straight wall, joined again.

The ridge of a count map is cut wherever other ridges cross it (arcs from a corner, the
tails of a bundle), so one wall often comes out as several collinear line segments with
short gaps between them. Each piece then has only part of the wall's echoes, and a sparse
log (a robot passing a wall once) may leave every piece below the echoes a surface needs.
Line segments that are nearly parallel (:data:`MERGE_ANGLE_RAD`), lie on one line
(:data:`MERGE_OFFSET_M`) and leave a gap shorter than :data:`MERGE_GAP_M` between them are
one surface: their cells are pooled and fitted again. A doorway (a gap of most of a metre)
and the two walls of a corridor (far more than the offset apart) stay separate.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.extraction.graphs import components
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit

__all__ = ["MERGE_ANGLE_RAD", "MERGE_GAP_M", "MERGE_OFFSET_M", "merge_collinear"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Largest angle between two pieces of one wall (rad).
MERGE_ANGLE_RAD = np.deg2rad(5.0)
#: Largest distance (m) of one piece's ends from the other's line.
MERGE_OFFSET_M = 0.05
#: Longest gap (m) between two pieces of one wall, along it.
MERGE_GAP_M = 0.30


def _line_frames(fits: list[SurfaceFit]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each line's point, unit direction and the two ends' positions along it."""
    c = np.array([f.params["point"] for f in fits], dtype=np.float64).reshape(-1, 2)
    t = np.array([f.params["direction"] for f in fits], dtype=np.float64).reshape(-1, 2)
    ends = np.stack([f.polyline[[0, -1]] for f in fits]) if fits else np.zeros((0, 2, 2))
    return c, t, ends


def merge_collinear(
    fits: list[SurfaceFit], cells: list[SurfaceCells], *, cell: float
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
    line = [i for i, f in enumerate(fits) if f.model == "line" and not f.closed]
    if len(line) < 2:
        return list(fits), list(cells)
    c, t, ends = _line_frames([fits[i] for i in line])
    # only nearly parallel pairs are tested further (a few per cent of all pairs)
    i, j = np.nonzero(np.triu(np.abs(t @ t.T) >= np.cos(MERGE_ANGLE_RAD), 1))
    ok = _on_line(c[i], t[i], ends[i], ends[j]) & _on_line(c[j], t[j], ends[j], ends[i])
    i, j = i[ok], j[ok]
    if i.size == 0:
        return list(fits), list(cells)
    _, label = components(len(line), i, j)
    out_fits: list[SurfaceFit] = []
    out_cells: list[SurfaceCells] = []
    groups: dict[int, list[int]] = {}
    for k, piece in enumerate(line):
        groups.setdefault(int(label[k]), []).append(piece)
    group_of = {i: g for g, members in groups.items() if len(members) > 1 for i in members}
    pooled = {
        g: _pool([cells[m] for m in members], [fits[m] for m in members])
        for g, members in groups.items()
        if len(members) > 1
    }
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


def _on_line(c: FloatArray, t: FloatArray, own: FloatArray, other: FloatArray) -> BoolArray:
    """Whether each ``other`` segment lies on the line ``c + u t`` of its ``own`` partner:
    both its ends within the offset, and the gap between the two along ``t`` short."""
    normal = np.stack((-t[:, 1], t[:, 0]), axis=1)
    rel = other - c[:, None, :]  # (pair, end, xy)
    offset = np.abs(np.einsum("pex,px->pe", rel, normal)).max(axis=1)
    along = np.einsum("pex,px->pe", rel, t)
    mine = np.einsum("pex,px->pe", own - c[:, None, :], t)
    gap = np.maximum(along.min(axis=1) - mine.max(axis=1), mine.min(axis=1) - along.max(axis=1))
    return np.asarray((offset <= MERGE_OFFSET_M) & (gap <= MERGE_GAP_M))


def _pool(pieces: list[SurfaceCells], fits: list[SurfaceFit]) -> SurfaceCells:
    """The pieces' cells as one surface, ordered along the longest piece's direction."""
    longest = max(range(len(fits)), key=lambda k: fits[k].length_m)
    t = np.asarray(fits[longest].params["direction"], dtype=np.float64)
    x = np.concatenate([p.x for p in pieces])
    y = np.concatenate([p.y for p in pieces])
    w = np.concatenate([p.weight for p in pieces])
    u = x * t[0] + y * t[1]
    order = np.argsort(u, kind="stable")
    u = u[order]
    return SurfaceCells(x[order], y[order], u - u[0], w[order], False)
