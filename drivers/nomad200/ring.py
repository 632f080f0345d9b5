"""The Nomad 200 Sensus 200 sonar ring, in SI units: the one place these numbers live.

Sixteen Polaroid 6500 transducers sit on a ring of radius :data:`RADIUS` round the turret
centre. Sonar ``i`` looks along ``turret + i * 22.5 deg`` (counter-clockwise, sonar 0
along the turret heading) and is mounted at ``RADIUS * (cos, sin)`` of that angle in the
turret frame. The robot reports each range from the transducer **face**, in whole inches.

The mount table is given as read-only arrays indexed by sonar id: :data:`IDS`,
:data:`HEADINGS` (rad, in ``[0, 2 pi)``), :data:`MOUNT_X` and :data:`MOUNT_Y` (m).

Examples
--------
>>> N_SONARS, RADIUS, round(float(np.rad2deg(STEP)), 3)
(16, 0.22, 22.5)
>>> round(float(MOUNT_Y[4]), 6), round(float(np.rad2deg(HEADINGS[4])), 6)
(0.22, 90.0)
"""

from __future__ import annotations

from typing import Any, Final, TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "HALF_BEAMWIDTH",
    "HEADINGS",
    "IDS",
    "MAX_RANGE",
    "MIN_RANGE",
    "MOUNT_X",
    "MOUNT_Y",
    "N_SONARS",
    "RADIUS",
    "STEP",
]

#: transducers on the ring
N_SONARS: Final = 16
#: ring radius: turret centre to transducer face (m)
RADIUS: Final = 0.22
#: angle between neighbouring transducers (rad), counter-clockwise
STEP: Final = 2.0 * np.pi / N_SONARS
#: Polaroid 6500 half beam width (rad): the 12.5 deg the 1999 paper uses
HALF_BEAMWIDTH: Final = float(np.deg2rad(12.5))
#: shortest usable range from the transducer face (m)
MIN_RANGE: Final = 0.15
#: longest usable range from the transducer face (m)
MAX_RANGE: Final = 10.7


_A = TypeVar("_A", bound=NDArray[Any])


def _frozen(a: _A) -> _A:
    a.setflags(write=False)
    return a


#: sonar ids 0..15
IDS: Final[NDArray[np.int_]] = _frozen(np.arange(N_SONARS))
#: line of sight of each sonar in the turret frame (rad)
HEADINGS: Final[NDArray[np.float64]] = _frozen(np.asarray(IDS * STEP, dtype=np.float64))
#: mount position of each transducer face in the turret frame (m)
MOUNT_X: Final[NDArray[np.float64]] = _frozen(np.asarray(RADIUS * np.cos(HEADINGS), np.float64))
MOUNT_Y: Final[NDArray[np.float64]] = _frozen(np.asarray(RADIUS * np.sin(HEADINGS), np.float64))
