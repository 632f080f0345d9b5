"""A wall is not continued through a stretch whose front no beam crossed (``cut_unseen``)."""

from __future__ import annotations

import numpy as np

from sonarproc.surfaces.echoes.unseen import cut_unseen, facing_views
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import FreeCones


def _cells(x: np.ndarray, y: np.ndarray) -> SurfaceCells:
    return SurfaceCells(x, y, np.hypot(x - x[0], y - y[0]), np.ones(x.size), False)


def _u_hall(
    middle_range: float,
) -> tuple[list[SurfaceFit], list[SurfaceCells], list[np.ndarray], FreeCones]:
    """The end walls of a U hall's two arms (y = 6, x 0 .. 2.5 and 5.5 .. 8) fitted as one
    line, with echo points on the two arms only, heard by sensors below them; sensors
    between the arms (y = 3) look north and range ``middle_range``: 2.5 m (a block
    between the arms from y = 5.5 up) or 3 m (nothing between them: their sound reached
    the line)."""
    xe = np.r_[np.linspace(0.1, 2.4, 24), np.linspace(5.6, 7.9, 24)]
    wall = fit_surfaces([_cells(np.linspace(0.0, 8.0, 801), np.full(801, 6.0))], cell=0.01)[0]
    assert isinstance(wall, SurfaceFit)
    xm = np.arange(2.4, 5.65, 0.05)
    xy = np.r_[np.c_[xe, np.full(xe.size, 5.3)], np.c_[xm, np.full(xm.size, 3.0)]]
    rng = np.r_[np.full(xe.size, 0.7), np.full(xm.size, middle_range)]
    cones = FreeCones.of(xy, np.full(xy.shape[0], np.pi / 2), np.full(xy.shape[0], 0.2), rng)
    return [wall], [_cells(xe, np.full(xe.size, 6.0))], [np.arange(xe.size)], cones


def test_a_line_through_a_stretch_no_beam_reached_is_cut_there() -> None:
    fits, pts, reads, cones = _u_hall(2.5)
    out, out_pts, out_reads = cut_unseen(fits, pts, reads, cones, margin=0.03, cell=0.01)
    ends = [(round(float(f.polyline[0, 0]), 2), round(float(f.polyline[-1, 0]), 2)) for f in out]
    # each arm's end wall runs from the hall's side wall to its last echo, within a step
    assert ends == [(0.0, 2.4), (5.6, 8.0)]
    assert [r.tolist() for r in out_reads] == [list(range(24)), list(range(24, 48))]
    assert [p.size for p in out_pts] == [24, 24]
    assert all(f.model == "line" for f in out)


def test_a_line_through_a_stretch_the_beams_reached_stays_whole() -> None:
    # the sound of the sensors between the arms reached the line and came back from it:
    # nobody heard through the stretch, which stays bridged
    fits, pts, reads, cones = _u_hall(3.0)
    out, _, _ = cut_unseen(fits, pts, reads, cones, margin=0.03, cell=0.01)
    assert len(out) == 1 and out[0] is fits[0]


def test_facing_views_count_square_readings_that_reached_or_fell_short() -> None:
    # the line y = 1 and its normal towards the sensors; sensors at x = 0 and 0.1 face it,
    # one at x = 0.05 looks 45 degrees off its normal (a wall there would not echo to it)
    xy = [[0.0, 0.0], [0.1, 0.0], [0.0, 0.0], [0.1, 0.0], [0.05, 0.0]]
    heading = [np.pi / 2] * 4 + [np.pi / 4]
    c = FreeCones.of(xy, heading, [0.2] * 5, [2.0, 2.0, 0.5, 0.98, 3.0])
    pts = [[0.05, 1.0], [0.05, 1.5], [1.05, 1.0]]
    reached, short = facing_views(pts, [0.0, -1.0], c, margin=0.03)
    # 0.98 m is within the 3 cm tolerance of the line at 1 m: it reached it
    assert reached.tolist() == [2, 2, 0] and short.tolist() == [1, 2, 0]
