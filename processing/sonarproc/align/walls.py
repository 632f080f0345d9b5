"""The walls a map-based refinement adjusts the poses on, from the readings' tangent votes.

:func:`find_walls` finds the walls under some poses
(:func:`sonarproc.surfaces.echoes.tangents.tangent_lines`) and keeps, of the readings
each wall returned, those whose beam axis meets it near its normal
(:data:`AXIS_FRACTION`): an echo off the axis is weaker and its range longer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.align.echoes import EchoRays
from sonarproc.align.track import wrap
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.echoes.tangents import tangent_lines

__all__ = ["AXIS_FRACTION", "WALL_MIN_VOTES", "WALL_TOL_M", "Walls", "find_walls"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: A reading belongs to a wall when its range tangent lies within this (m) of the wall's
#: line: five range deviations, and under the pose errors the graph leaves (about 1 cm).
WALL_TOL_M = 0.05
#: Fewest readings per wall: a wall seen from fewer places hardly constrains the poses,
#: and fewer readings can pair by chance into a line.
WALL_MIN_VOTES = 20
#: Echo points further apart along a line (m) start another wall: a doorway or a gap
#: (the surfaces' own bridge, see :mod:`sonarproc.pipeline.surfacefit`).
WALL_BRIDGE_M = 0.30
#: Shortest wall (m): a few beam footprints, so that a corner's or an edge's echoes
#: (a point that looks like a short line) are not taken for a wall.
WALL_MIN_SPREAD_M = 0.5
#: An echo is used when its wall's normal lies within this fraction of the half beam
#: width of the sensor's axis. Off the axis the echo is weaker (the beam pattern), so it
#: crosses the receiver's threshold later (time walk) and its range is long, by more
#: the weaker it is: centimetres at a few metres near the beam's edge. Those errors are
#: the same each time a wall is seen from the same place, and a map-based refinement
#: would bend the track to fit them.
AXIS_FRACTION = 0.5


@dataclass(frozen=True, eq=False)
class Walls:
    """Walls found under some poses: the rays each returned and a start for its line."""

    ray: IntArray  # rays that a wall returned (M,), indices into all rays
    wall: IntArray  # the wall of each (M,), 0 .. L - 1
    centre: FloatArray  # a point of each wall (L, 2): lines are placed relative to it
    phi: FloatArray  # direction of each wall's normal (L,), away from its sensors
    #: angle (M,) between each ray's line of sight and its wall's normal (rad), under the
    #: poses the walls were found at: how far off the beam's axis the echo came back
    incidence: FloatArray

    @property
    def count(self) -> int:
        return int(self.phi.size)


def find_walls(rays: EchoRays, corrected: FloatArray) -> Walls:
    """The walls under the corrected poses (N, 3), from the readings' tangent votes."""
    pose = corrected[rays.reading]
    xy, look = rays.sensors(pose[:, 0], pose[:, 1], pose[:, 2])
    geom = EchoGeometry(xy, look, rays.half_beam, rays.range_m)
    segs, _ = tangent_lines(geom, tol=WALL_TOL_M, min_votes=WALL_MIN_VOTES,
                            bridge_m=WALL_BRIDGE_M, min_spread_m=WALL_MIN_SPREAD_M)  # fmt: skip
    if not segs:
        z = np.zeros(0, dtype=np.intp)
        return Walls(z, z.copy(), np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    ray = np.concatenate([g.readings for g in segs]).astype(np.intp)
    wall = np.repeat(np.arange(len(segs)), [g.readings.size for g in segs]).astype(np.intp)
    centre = np.array([g.points.mean(axis=0) for g in segs])
    phi = np.array([math.atan2(g.normal[1], g.normal[0]) for g in segs])
    # near the axis only: an echo off the axis is weaker, and its range longer (time walk)
    incidence = np.abs(wrap(look[ray] - phi[wall]))
    near = incidence <= AXIS_FRACTION * rays.half_beam[ray]
    return Walls(ray[near], wall[near], centre, phi, incidence[near])
