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
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from sonarproc.surfaces.extract import SurfaceCells
from sonarproc.surfaces.models import SurfaceFailure, SurfaceFit, fit_surface

__all__ = ["MERGE_ANGLE_RAD", "MERGE_GAP_M", "MERGE_OFFSET_M", "merge_collinear"]

FloatArray = npt.NDArray[np.float64]

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
    >>> fits = [fit_surface(c, cell=0.01) for c in pieces]
    >>> merged, _ = merge_collinear(fits, pieces, cell=0.01)
    >>> [(f.model, round(f.length_m, 2)) for f in merged]
    [('line', 1.99)]
    """
    line = [i for i, f in enumerate(fits) if f.model == "line" and not f.closed]
    if len(line) < 2:
        return list(fits), list(cells)
    c, t, ends = _line_frames([fits[i] for i in line])
    cos = np.abs(t @ t.T)
    normal = np.stack((-t[:, 1], t[:, 0]), axis=1)
    # offsets of j's two ends from i's line, and both pieces' intervals along i's direction
    rel = ends[None, :, :, :] - c[:, None, None, :]  # (i, j, end, xy)
    offset = np.abs(np.einsum("ijex,ix->ije", rel, normal)).max(axis=2)
    along_j = np.einsum("ijex,ix->ije", rel, t)
    own = np.einsum("iex,ix->ie", ends - c[:, None, :], t)
    lo_i, hi_i = own.min(axis=1)[:, None], own.max(axis=1)[:, None]
    lo_j, hi_j = along_j.min(axis=2), along_j.max(axis=2)
    gap = np.maximum(lo_j - hi_i, lo_i - hi_j)
    join = (cos >= np.cos(MERGE_ANGLE_RAD)) & (offset <= MERGE_OFFSET_M) & (gap <= MERGE_GAP_M)
    join &= join.T  # each piece must lie on the other's line
    np.fill_diagonal(join, False)
    if not join.any():
        return list(fits), list(cells)
    _, label = connected_components(coo_matrix(join), directed=False)
    out_fits: list[SurfaceFit] = []
    out_cells: list[SurfaceCells] = []
    groups: dict[int, list[int]] = {}
    for k, i in enumerate(line):
        groups.setdefault(int(label[k]), []).append(i)
    group_of = {i: g for g, members in groups.items() if len(members) > 1 for i in members}
    emitted: set[int] = set()
    for i, (f, cc) in enumerate(zip(fits, cells, strict=True)):
        g = group_of.get(i)
        if g is None:
            out_fits.append(f)
            out_cells.append(cc)
            continue
        if g in emitted:  # the group stands where its first piece stood
            continue
        emitted.add(g)
        members = groups[g]
        joined = _pool([cells[m] for m in members], [fits[m] for m in members])
        new = fit_surface(joined, cell=cell)
        if isinstance(new, SurfaceFailure):  # keep the pieces as they were
            out_fits += [fits[m] for m in members]
            out_cells += [cells[m] for m in members]
        else:
            out_fits.append(new)
            out_cells.append(joined)
    return out_fits, out_cells


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
