"""Sonar arcs: where each echo could have come from, and how arcs become map cells.

A reading with transmitter T, receiver R and path length ``p`` (tof x speed of sound)
puts its reflector on the ellipse with foci T and R (a circle when T = R), limited to the
part inside both beams. The geometry is computed once per run, then used for the map's
extent and for drawing:

>>> import numpy as np
>>> from sonarproc.grid import Grid
>>> arcs = arc_geometry([[0, 0]], [0.0], [[0, 0]], [0.0], [2.0],
...                     tx_half_beamwidth=np.pi / 2, rx_half_beamwidth=np.pi / 2)
>>> grid = Grid.covering(*arcs.bounds(), cell=0.01)
>>> counts = rasterize(arcs, grid)
>>> int(counts.max()), counts.shape == grid.shape
(1, True)

The engines are private modules: ``_geometry`` (ellipses and beam intervals), ``_plan``,
``_bounds``, ``_fill`` and ``_raster`` (gap-free 8-connected chains, vectorised over all arcs:
pieces, proven bounds, float32 cell keys, repeat removal and scattering), ``_sampled``
(paper-style samples at a fixed angular step) and ``_cells`` (count maps and per-arc cells).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarlog import TransducerPoses
from sonarproc.arcs._cells import RASTER_METHODS, arc_cell_keys, arc_cells, rasterize
from sonarproc.arcs._geometry import ArcGeometry, arc_geometry, point_at, tangent_at
from sonarproc.arcs._sampled import arc_samples, sample_anomalies

__all__ = [
    "RASTER_METHODS",
    "ArcGeometry",
    "arc_cell_keys",
    "arc_cells",
    "arc_geometry",
    "arc_samples",
    "arcs_of",
    "point_at",
    "rasterize",
    "sample_anomalies",
    "tangent_at",
]


def arcs_of(poses: TransducerPoses, path: npt.NDArray[np.float64]) -> ArcGeometry:
    """The arcs of readings whose transducer poses and path lengths a log gave.

    Parameters
    ----------
    poses : sonarlog.TransducerPoses
        World poses and half beamwidths of each reading's transmitter and receiver.
    path : ndarray, (N,)
        Path lengths (m): tof x speed of sound.

    Returns
    -------
    ArcGeometry
    """
    return arc_geometry(
        poses.tx_xy,
        poses.tx_heading,
        poses.rx_xy,
        poses.rx_heading,
        path,
        tx_half_beamwidth=poses.tx_half_beamwidth,
        rx_half_beamwidth=poses.rx_half_beamwidth,
    )
