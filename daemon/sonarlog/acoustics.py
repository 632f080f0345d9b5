"""The speed of sound in air, from the air temperature.

A log records the speed of sound it was written with (root attribute ``speed_of_sound``)
and, when that speed came from a temperature, the temperature too (``temperature_c``).

>>> round(speed_of_sound_at(20.0), 2)
343.21
>>> round(speed_of_sound_at(0.0), 1)
331.3
"""

from __future__ import annotations

import math

__all__ = ["SPEED_AT_0C", "TEMPERATURE_RANGE_C", "speed_of_sound_at"]

#: Speed of sound in dry air at 0 °C (m/s).
SPEED_AT_0C = 331.3
#: Temperatures accepted (°C): the range Polaroid rated its transducers for, with margin.
TEMPERATURE_RANGE_C = (-40.0, 85.0)


def speed_of_sound_at(temperature_c: float) -> float:
    """Speed of sound in dry air (m/s) at ``temperature_c`` degrees Celsius.

    Uses the ideal-gas law, ``331.3 * sqrt(1 + T / 273.15)``.

    Parameters
    ----------
    temperature_c : float
        Air temperature in °C, within :data:`TEMPERATURE_RANGE_C`.

    Returns
    -------
    float
        The speed of sound in m/s.

    Raises
    ------
    ValueError
        The temperature is not finite or lies outside :data:`TEMPERATURE_RANGE_C`.
    """
    lo, hi = TEMPERATURE_RANGE_C
    if not (math.isfinite(temperature_c) and lo <= temperature_c <= hi):
        raise ValueError(f"temperature_c must be within [{lo:g}, {hi:g}] °C, got {temperature_c}")
    return SPEED_AT_0C * math.sqrt(1.0 + temperature_c / 273.15)
