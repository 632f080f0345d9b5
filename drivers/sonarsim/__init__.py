"""The acoustic world: surfaces, specular sonar echoes and sensor arrays.

>>> from sonarsim import World, load_world, first_echo_path, echoes
>>> from sonarsim import load_scenario, simulate
"""

from sonarsim.scenario import Scenario, ScenarioError, load_scenario, scenario_from_dict
from sonarsim.search import (
    HALF_BEAMWIDTH,
    MAX_RANGE,
    MIN_RANGE,
    Echoes,
    echoes,
    first_echo_path,
    pair_echoes,
)
from sonarsim.segments import Segments, Surface
from sonarsim.simulation import SimResult, simulate
from sonarsim.specular import Sensors
from sonarsim.surfaces import (
    Circle,
    Curve,
    Polyline,
    SmoothPolyline,
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
    "Scenario",
    "ScenarioError",
    "Segments",
    "Sensors",
    "SimResult",
    "SmoothPolyline",
    "Surface",
    "World",
    "WorldError",
    "echoes",
    "first_echo_path",
    "load_scenario",
    "load_world",
    "pair_echoes",
    "polynomial",
    "profile",
    "room",
    "scenario_from_dict",
    "simulate",
    "sinusoid",
    "wall",
    "world_from_dict",
]
