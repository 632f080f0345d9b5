"""The Nomad 200 Sensus sonar ring as a sonarlog sensors table.

The geometry is :mod:`nomad200.ring`'s: sixteen Polaroid transducers on a ring of radius
0.22 m; sonar ``i`` looks at ``i * 22.5 deg`` in the turret frame (counter-clockwise,
sonar 0 along the turret heading), half beam width 12.5 deg, usable range 0.15 to 10.7 m.

Range origin: the robot reports each range from the transducer **face**. The table puts
each sensor at its face (on the ring), so the reported range is the distance from the
logged sensor position and the round trip is ``tof = 2 * range / c`` with no offset.
"""

from __future__ import annotations

import numpy as np

from nomad200 import ring
from sonarlog import SENSOR_DTYPE

__all__ = ["HALF_BEAMWIDTH", "MAX_RANGE", "MIN_RANGE", "N_SONARS", "RING_RADIUS", "ring_sensors"]

N_SONARS = ring.N_SONARS
RING_RADIUS = ring.RADIUS
HALF_BEAMWIDTH = ring.HALF_BEAMWIDTH
MIN_RANGE = ring.MIN_RANGE
MAX_RANGE = ring.MAX_RANGE


def ring_sensors() -> np.ndarray:
    """Return the 16-row sensors table of the Nomad ring (SENSOR_DTYPE, SI units).

    Examples
    --------
    >>> t = ring_sensors()
    >>> len(t), round(float(t["heading"][4]), 4), round(float(t["y"][4]), 2)
    (16, 1.5708, 0.22)
    """
    table = np.zeros(N_SONARS, dtype=SENSOR_DTYPE)
    table["id"] = ring.IDS
    table["x"] = ring.MOUNT_X
    table["y"] = ring.MOUNT_Y
    table["heading"] = ring.HEADINGS
    table["half_beamwidth"] = HALF_BEAMWIDTH
    table["min_range"] = MIN_RANGE
    table["max_range"] = MAX_RANGE
    return table
