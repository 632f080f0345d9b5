"""The acoustic world: surfaces, specular sonar echoes and sensor arrays.

>>> from sonarsim import World, load_world, first_echo_path, echoes
"""

from sonarsim.echoes import (
    HALF_BEAMWIDTH,
    MAX_RANGE,
    MIN_RANGE,
    Echoes,
    echoes,
    first_echo_path,
    pair_echoes,
)
from sonarsim.specular import Sensors
from sonarsim.surfaces import (
    Circle,
    Curve,
    Polyline,
    Segments,
    SmoothPolyline,
    Surface,
    polynomial,
    profile,
    room,
    sinusoid,
    wall,
)
from sonarsim.world import World, WorldError, load_world, world_from_dict

__all__ = [
    "HALF_BEAMWIDTH",
    "MAX_RANGE",
    "MIN_RANGE",
    "Circle",
    "Curve",
    "Echoes",
    "Polyline",
    "Segments",
    "Sensors",
    "SmoothPolyline",
    "Surface",
    "World",
    "WorldError",
    "echoes",
    "first_echo_path",
    "load_world",
    "pair_echoes",
    "polynomial",
    "profile",
    "room",
    "sinusoid",
    "wall",
    "world_from_dict",
]
