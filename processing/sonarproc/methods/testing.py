"""Analytic readings for checking methods: a flat wall, a corner, a cylinder.

Each helper places monostatic sensors, computes each one's first echo off the exact
surface (:func:`sonarproc.methods.echo_model.first_echo_path`, no noise) and returns the
:class:`~sonarproc.methods.base.Beams` and a 1 cm grid over their arcs, so a method's
``build`` can be called without a log.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarlog import TransducerPoses
from sonarlog.schema import empty_readings
from sonarproc.arcs import arcs_of
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams
from sonarproc.methods.echo_model import first_echo_path

__all__ = ["beams_facing", "corner_beams", "cylinder_beams", "flat_wall_beams"]

FloatArray = npt.NDArray[np.float64]

#: Half beamwidth of the test sensors (rad): a Polaroid-like 15 degrees.
HALF_BEAM = np.radians(15.0)


def beams_facing(
    xy: npt.ArrayLike, heading: npt.ArrayLike, surface: npt.ArrayLike, *, cell: float = 0.01
) -> tuple[Beams, Grid]:
    """Monostatic sensors at ``xy`` looking along ``heading``, hearing ``surface`` first.

    Sensors that hear nothing are dropped. Returns the beams and a grid over their arcs.
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    h = np.asarray(heading, dtype=np.float64).reshape(-1)
    half = np.full(h.shape, HALF_BEAM)
    path = first_echo_path(p, h, half, p, h, half, surface)
    ok = np.isfinite(path)
    p, h, half, path = p[ok], h[ok], half[ok], path[ok]
    n = p.shape[0]
    readings = empty_readings(n)
    readings["x"], readings["y"], readings["theta"] = p[:, 0], p[:, 1], h
    readings["tof"] = path / 343.3
    poses = TransducerPoses(
        p, h, p.copy(), h.copy(), half, half.copy(), np.zeros(n), np.full(n, 10.0)
    )
    beams = Beams(readings, poses, path, arcs_of(poses, path))
    return beams, Grid.covering(*beams.arcs.bounds(), cell=cell)


def flat_wall_beams(n: int = 60) -> tuple[Beams, Grid]:
    """Sensors along y = 0 (x in [0, 2] m) looking at the wall y = 1 m; ~1-cm steps apart."""
    xs = np.linspace(-1.0, 3.0, 4001)
    wall = np.column_stack((xs, np.ones_like(xs)))
    sx = np.linspace(0.0, 2.0, n)
    rng = np.random.default_rng(1)
    heading = np.pi / 2 + rng.uniform(-0.3, 0.3, n)
    return beams_facing(np.column_stack((sx, np.zeros(n))), heading, wall)


def corner_beams(n: int = 200) -> tuple[Beams, Grid]:
    """Sensors in the square (0.5, 1.5)^2 looking towards a right-angle corner at (2, 2)."""
    s = np.linspace(0.0, 2.0, 2001)
    corner = np.concatenate(
        (np.column_stack((s, np.full_like(s, 2.0))), np.column_stack((np.full_like(s, 2.0), s)))
    )
    rng = np.random.default_rng(2)
    xy = rng.uniform(0.5, 1.5, (n, 2))
    heading = rng.uniform(0.0, np.pi / 2, n)
    return beams_facing(xy, heading, corner)


def cylinder_beams(n: int = 72, radius: float = 0.3) -> tuple[Beams, Grid]:
    """A ring of sensors 1 m from the centre of a cylinder of ``radius`` at the origin."""
    phi = np.linspace(0.0, 2 * np.pi, 2000, endpoint=False)
    circle = radius * np.column_stack((np.cos(phi), np.sin(phi)))
    ang = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    xy = np.column_stack((np.cos(ang), np.sin(ang)))
    rng = np.random.default_rng(3)
    heading = ang + np.pi + rng.uniform(-0.2, 0.2, n)
    return beams_facing(xy, heading, circle)
