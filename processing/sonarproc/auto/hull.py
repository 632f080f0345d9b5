"""The echo refit's hull: a refitted profile against the echo points it was fitted to.

A refit must not leave the hull of its points (:func:`~sonarproc.auto.holdout.hull_excess`)
by more than a few cells (:func:`~sonarproc.auto.refit_rounds.hull_tolerance`), on the
sensors' side. A first echo comes from the part of the surface nearest the sensors, so
echo points are thin where the surface recedes from them (a wave's crests seen from
below). Towards the sensors a refit is held to the local hull; on the far side, to the
farthest of all its points (:func:`sensor_side` says which side is which). (The
candidates' fits are judged by the beam-range guard instead,
:mod:`sonarproc.auto.beam_guard`.)
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.pipeline.selection import Beams

__all__ = ["HULL_WINDOW_CELLS", "SIDE_SHARE", "sensor_side"]

FloatArray = npt.NDArray[np.float64]

#: Width (cells) of the hull's bins along x.
HULL_WINDOW_CELLS = 10
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
