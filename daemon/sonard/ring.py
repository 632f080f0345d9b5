"""The Nomad 200 Sensus sonar ring as a sonarlog sensors table.

Sixteen Polaroid transducers on a ring of radius 0.22 m; sonar ``i`` looks at
``i * 22.5 deg`` in the turret frame (counter-clockwise, sonar 0 along the turret heading),
half beam width 12.5 deg, usable range 0.15 to 10.7 m.

Range origin: the robot reports each range from the transducer **face**. The table puts
each sensor at its face (on the 0.22 m ring), so the reported range is the distance from
the logged sensor position and the round trip is ``tof = 2 * range / c`` with no offset.
"""

from __future__ import annotations

import numpy as np

from sonarlog import SENSOR_DTYPE

__all__ = ["HALF_BEAMWIDTH", "MAX_RANGE", "MIN_RANGE", "N_SONARS", "RING_RADIUS", "ring_sensors"]

N_SONARS = 16
RING_RADIUS = 0.22
HALF_BEAMWIDTH = float(np.deg2rad(12.5))
MIN_RANGE = 0.15
MAX_RANGE = 10.7


def ring_sensors() -> np.ndarray:
    """Return the 16-row sensors table of the Nomad ring (SENSOR_DTYPE, SI units).

    Examples
    --------
    >>> t = ring_sensors()
    >>> len(t), round(float(t["heading"][4]), 4), round(float(t["y"][4]), 2)
    (16, 1.5708, 0.22)
    """
    table = np.zeros(N_SONARS, dtype=SENSOR_DTYPE)
    ids = np.arange(N_SONARS)
    heading = np.deg2rad(22.5 * ids)
    table["id"] = ids
    table["x"] = RING_RADIUS * np.cos(heading)
    table["y"] = RING_RADIUS * np.sin(heading)
    table["heading"] = heading
    table["half_beamwidth"] = HALF_BEAMWIDTH
    table["min_range"] = MIN_RANGE
    table["max_range"] = MAX_RANGE
    return table
