"""A surface's support is counted on the geometry it is reported with.

A robot turning on one spot ranges the same distance from front sonars a few
centimetres apart (a Pioneer 3-DX's front ring, from its ARIA parameter file). A line
fitted through those echo points turns away from every beam that heard it: no reading's
foot lies on it, so no reading echoes from it as it is reported, although the echoes
gathered against the line before the refit came from several viewpoints.
"""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces.echoes.refine import refine_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry, echo_points
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.models import SurfaceFit

CELL = 0.01
HALF_BEAM = math.radians(15.0)
#: Front sonars of a Pioneer 3-DX: x, y (m) and heading (deg) on the robot.
FRONT = ((0.069, 0.136, 90.0), (0.114, 0.119, 50.0), (0.148, 0.078, 30.0),
         (0.166, 0.027, 10.0), (0.166, -0.027, -10.0), (0.148, -0.078, -30.0))  # fmt: skip
RANGE_M = 2.465


def _turning_on_the_spot() -> EchoGeometry:
    """The robot at the origin turning from -110 to +10 deg in 5 deg steps; each sonar
    whose beam points within 15 deg of +x ranges ``RANGE_M``."""
    xy, heading = [], []
    for phi in np.radians(np.arange(-110.0, 15.0, 5.0)):
        for x, y, a in FRONT:
            h = phi + math.radians(a)
            if abs(h) <= math.radians(15.0) + 1e-9:
                c, s = math.cos(phi), math.sin(phi)
                xy.append((c * x - s * y, s * x + c * y))
                heading.append(h)
    n = len(xy)
    return EchoGeometry(np.array(xy), np.array(heading), np.full(n, HALF_BEAM),
                        np.full(n, RANGE_M))  # fmt: skip


def _line_at(x: float) -> tuple[SurfaceFit, SurfaceCells]:
    """A ridge along x = const, y from -1 to 1.2 m."""
    u = np.arange(0.0, 2.2 + 1e-9, CELL)
    cells = SurfaceCells(np.full(u.size, x), -1.0 + u, u, np.ones_like(u), False)
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit)
    return fit, cells


def test_a_line_no_reading_echoes_from_as_reported_is_not_reported() -> None:
    echoes = _turning_on_the_spot()
    assert echoes.size == 32
    fit, cells = _line_at(RANGE_M + 0.166)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    # every reported surface rests on readings that echo from it as it is reported
    for f in out:
        got = echo_points([f.polyline], [f.closed], echoes, tol=0.03)[0]
        assert got.readings.size >= 5, (f.model, f.length_m, f.arcs, got.readings.size)
    assert out == []


def test_a_wall_driven_past_keeps_its_support() -> None:
    """Sensors every 5 cm along y = 0 looking up at the wall y = 1: one wall, every
    reading echoing from it as reported."""
    x = np.arange(0.1, 3.9 + 1e-9, 0.05)
    r = 1.0 + np.random.default_rng(0).normal(0.0, 0.005, x.size)
    echoes = EchoGeometry(np.c_[x, np.zeros(x.size)], np.full(x.size, math.pi / 2),
                          np.full(x.size, HALF_BEAM), r)  # fmt: skip
    u = np.arange(0.0, 4.0 + 1e-9, CELL)
    cells = SurfaceCells(u, np.ones_like(u), u, np.ones_like(u), False)
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    assert len(out) == 1
    got = echo_points([out[0].polyline], [False], echoes, tol=0.03)[0]
    assert got.readings.size == x.size
