"""Record layouts of the simulator's results.

``sonarsim`` sits below ``sonarlog`` in the dependency order (drivers <- daemon <-
processing), so it cannot import the log format; these dtypes repeat sonarlog v1's
``SENSOR_DTYPE`` and ``READING_DTYPE`` field for field (the sonarlog v1 format), and a test
checks that they stay equal.
"""

from __future__ import annotations

import numpy as np

SENSOR_DTYPE = np.dtype(
    [
        ("id", "<i2"),
        ("x", "<f8"),
        ("y", "<f8"),
        ("heading", "<f8"),
        ("half_beamwidth", "<f8"),
        ("min_range", "<f8"),
        ("max_range", "<f8"),
    ]
)
"""One transducer: mount in the turret (array) frame, beam and range limits."""

READING_DTYPE = np.dtype(
    [
        ("t", "<f8"),
        ("tx", "<i2"),
        ("rx", "<i2"),
        ("echo", "u1"),
        ("tof", "<f8"),
        ("x", "<f8"),
        ("y", "<f8"),
        ("theta", "<f8"),
        ("turret", "<f8"),
        ("flags", "<u2"),
    ]
)
"""One echo: firing time, pair, echo rank, time of flight, robot pose, flags."""

FLAG_NO_ECHO = 1
"""Bit 0 of ``flags``: out of range, no echo."""
FLAG_CROSSTALK = 2
"""Bit 1 of ``flags``: suspected crosstalk."""

SPEED_OF_SOUND = 343.3
"""Speed of sound in air used by the paper (m/s)."""
