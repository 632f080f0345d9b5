"""The guard rails' hull: a fitted profile against the points the data put on the surface.

A profile must not leave the hull of its points (:func:`~sonarproc.auto.holdout.hull_excess`)
by more than a few cells; two things make that hull the data's and not only the map's.

* **The readings' echo points** (a candidate's fit, :func:`data_hull_excess`). Where a
  fit leaves its map's local hull, each reading whose range the fit predicts within the
  tolerance has an echo point on the surface
  (:func:`~sonarproc.auto.refit_rounds.echo_points`); those points join the hull. A
  sparse map misses stretches that the readings see; a fit that swings where no reading
  echoes stays outside.
* **The sensors' side** (the echo refit, whose points are all echo points). A first echo
  comes from the part of the surface nearest the sensors, so echo points are thin where
  the surface recedes from them (a wave's crests seen from below). Towards the sensors
  a refit is held to the local hull; on the far side, to the farthest of all its points
  (:func:`sensor_side` says which side is which).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.auto.holdout import hull_excess
from sonarproc.auto.refit_rounds import echo_points
from sonarproc.auto.score import HULL_CELLS
from sonarproc.fit import PolarFit, PolyFit, SplineFit
from sonarproc.pipeline.selection import Beams

__all__ = ["HULL_READINGS", "HULL_WINDOW_CELLS", "SIDE_SHARE", "data_hull_excess", "sensor_side"]

FloatArray = npt.NDArray[np.float64]

#: Width (cells) of the hull's bins along x.
HULL_WINDOW_CELLS = 10
#: At most this many readings (evenly spread through the log) are asked for echo points:
#: a few hundred per metre of surface are plenty for a hull, and every fit that leaves
#: its map's hull asks them.
HULL_READINGS = 1500
#: Share of the sensors' positions that must lie on one side of a profile for that side
#: to count as theirs.
SIDE_SHARE = 0.95


def sensor_side(beams: Beams | None, curve: FloatArray) -> int:
    """Which side of a profile y(x) the sensors are on: +1 below it, -1 above, 0 both.

    Each transmitter and receiver position is compared with the profile at its x (the
    end values beyond the profile's ends); at least :data:`SIDE_SHARE` of them must lie
    on one side.

    Examples
    --------
    >>> from sonarproc.methods.testing import beams_facing
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> beams, _ = beams_facing([[0.1, 0.0], [0.5, 0.2]], [np.pi / 2] * 2, wall)
    >>> sensor_side(beams, wall), sensor_side(beams, wall - [0.0, 2.0]), sensor_side(None, wall)
    (1, -1, 0)
    """
    if beams is None or len(beams.path) == 0 or curve.shape[0] < 2:
        return 0
    p = beams.poses
    at = np.concatenate((p.tx_xy, p.rx_xy))
    below = float(np.mean(at[:, 1] < np.interp(at[:, 0], curve[:, 0], curve[:, 1])))
    return 1 if below >= SIDE_SHARE else -1 if below <= 1.0 - SIDE_SHARE else 0


def data_hull_excess(
    fit: PolyFit | SplineFit | PolarFit,
    px: FloatArray,
    py: FloatArray,
    beams: Beams | None,
    cell: float,
) -> float:
    """How far (m) ``fit`` leaves the hull of the map's points and the readings' echo points.

    Parameters
    ----------
    fit : PolyFit, SplineFit or PolarFit
        The fit judged (a closed polar fit against the map's points alone).
    px, py : ndarray
        The map's points (m).
    beams : Beams or None
        The readings (at most :data:`HULL_READINGS` of them are asked); None judges
        against the map's points alone.
    cell : float
        The grid's cell (m): the fit's sampling step, and the unit of the tolerance.

    Returns
    -------
    float
        The largest distance (m) along y of the fit outside the hull; 0 inside it.

    Examples
    --------
    A wall along y = 1 seen by one sensor at x = 0.5, and a map with points only at
    x = 0 and x = 1, 8 cm short of the wall. A fit along the wall leaves the map's hull
    by 8 cm; the reading's echo point at x = 0.5 is on the wall, and the fit stays
    within the hull that it widens.

    >>> from sonarproc.fit import PolyFit
    >>> from sonarproc.methods.testing import beams_facing
    >>> xs = np.linspace(-1, 2, 301)
    >>> wall_xy = np.column_stack((xs, np.ones_like(xs)))
    >>> beams, _ = beams_facing([[0.5, 0.0]], [np.pi / 2], wall_xy)
    >>> wall = PolyFit(0, np.array([1.0]), (0.0, 1.0))
    >>> px, py = np.array([0.0, 1.0]), np.array([0.92, 0.92])
    >>> round(data_hull_excess(wall, px, py, None, 0.01), 3)
    0.08
    >>> round(data_hull_excess(wall, px, py, beams, 0.01), 3)
    0.0
    """
    curve = fit.sample(cell)
    window = HULL_WINDOW_CELLS * cell
    excess = hull_excess(curve, px, py, window=window)
    if beams is None or isinstance(fit, PolarFit) or excess <= HULL_CELLS * cell:
        return excess
    n = len(beams.path)
    if n == 0 or curve.shape[0] < 3:
        return excess
    span = (float(curve[0, 0]), float(curve[-1, 0]))
    among = None if n <= HULL_READINGS else np.linspace(0, n - 1, HULL_READINGS).astype(np.intp)
    _, points = echo_points(fit, beams, span, step=cell, tol=HULL_CELLS * cell, among=among)
    if points.shape[0] == 0:
        return excess
    both_x, both_y = np.concatenate((px, points[:, 0])), np.concatenate((py, points[:, 1]))
    return hull_excess(curve, both_x, both_y, window=window)
