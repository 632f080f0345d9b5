"""The acoustic world: surfaces, specular sonar echoes and sensor arrays.

>>> from sonarsim import World, load_world, first_echo_path, echoes
>>> from sonarsim import load_scenario, simulate

The names are loaded on first use (:func:`__getattr__`): a program that needs one
module of the package (``sonarsim.transducer``'s beam model, say) does not pay for
importing the simulator.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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

#: Each exported name and the module that defines it.
_EXPORTS = {
    "Scenario": "sonarsim.scenario",
    "ScenarioError": "sonarsim.scenario",
    "load_scenario": "sonarsim.scenario",
    "scenario_from_dict": "sonarsim.scenario",
    "HALF_BEAMWIDTH": "sonarsim.search",
    "MAX_RANGE": "sonarsim.search",
    "MIN_RANGE": "sonarsim.search",
    "Echoes": "sonarsim.search",
    "echoes": "sonarsim.search",
    "first_echo_path": "sonarsim.search",
    "pair_echoes": "sonarsim.search",
    "Segments": "sonarsim.segments",
    "Surface": "sonarsim.segments",
    "SimResult": "sonarsim.simulation",
    "simulate": "sonarsim.simulation",
    "Sensors": "sonarsim.specular",
    "Circle": "sonarsim.surfaces",
    "Curve": "sonarsim.surfaces",
    "Polyline": "sonarsim.surfaces",
    "SmoothPolyline": "sonarsim.surfaces",
    "polynomial": "sonarsim.surfaces",
    "profile": "sonarsim.surfaces",
    "room": "sonarsim.surfaces",
    "sinusoid": "sonarsim.surfaces",
    "wall": "sonarsim.surfaces",
    "World": "sonarsim.world",
    "WorldError": "sonarsim.world",
    "load_world": "sonarsim.world",
    "world_from_dict": "sonarsim.world",
}

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


def __getattr__(name: str) -> Any:
    """An exported name, its module imported on first use (PEP 562)."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
