"""The scenario YAML schema (validated with pydantic).

A scenario names a world, a sensor array, a path of poses, which pairs listen,
imperfections and a seed; :mod:`sonarsim.scenario` turns it into readings. Lengths in
metres, times in seconds, angles in degrees (keys end in ``_deg``). See
``configs/scenarios/*.yaml`` for complete examples.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from nomad200 import ring

#: farthest a coordinate or length may reach (m): far beyond any building a robot maps,
#: and small enough that squared distances stay finite in float64
MAX_COORD = 1e5
#: most stops or sweep angles a scenario may ask for (a run is held in memory)
MAX_STEPS = 100_000
Coord = Annotated[float, Field(ge=-MAX_COORD, le=MAX_COORD)]
Point = tuple[Coord, Coord]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class SensorDefaults(_Model):
    """Beam and range of every transducer (default: Polaroid 6500 on the Nomad)."""

    half_beamwidth_deg: float = Field(default=math.degrees(ring.HALF_BEAMWIDTH), gt=0, lt=90)
    min_range: float = Field(default=ring.MIN_RANGE, ge=0, le=100)
    max_range: float = Field(default=ring.MAX_RANGE, gt=0, le=100)

    @model_validator(mode="after")
    def _ranges(self) -> SensorDefaults:
        if not self.max_range > self.min_range:
            raise ValueError("max_range must be greater than min_range")
        return self


class LinearArray(_Model):
    """``count`` sensors ``spacing`` apart from ``origin`` along ``direction_deg``."""

    type: Literal["linear"]
    count: int = Field(ge=1, le=10_000)
    spacing: float = Field(gt=0, le=MAX_COORD / 10_000)
    origin: Point = (0.0, 0.0)
    direction_deg: float = 0.0
    heading_deg: float = 90.0


class CircularArray(_Model):
    """A ring; sensor ``i`` at ``i * step_deg`` CCW from the array heading, facing out."""

    type: Literal["circular"]
    count: int = Field(default=ring.N_SONARS, ge=1, le=360)
    radius: float = Field(default=ring.RADIUS, gt=0, le=MAX_COORD)
    step_deg: float | None = None


class RandomArray(_Model):
    """Uniformly random positions and headings from a seeded generator."""

    type: Literal["random"]
    count: int = Field(ge=1, le=10_000)
    x_range: Point
    y_range: Point
    heading_range_deg: Point = (0.0, 360.0)
    seed: int | None = Field(default=None, ge=0)

    @model_validator(mode="after")
    def _order(self) -> RandomArray:
        for name in ("x_range", "y_range", "heading_range_deg"):
            lo, hi = getattr(self, name)
            if not hi >= lo:
                raise ValueError(f"{name} must be [low, high] with low <= high")
        return self


class SensorRow(_Model):
    """One explicitly placed sensor."""

    x: Coord
    y: Coord
    heading_deg: float
    id: int | None = Field(default=None, ge=0, le=32767)


class ExplicitArray(_Model):
    """Sensors listed one by one."""

    type: Literal["explicit"]
    sensors: list[SensorRow] = Field(min_length=1)


ArraySpec = Annotated[
    LinearArray | CircularArray | RandomArray | ExplicitArray, Field(discriminator="type")
]


class SensorFile(_Model):
    """A ``configs/sensors/*.yaml`` file: an array and its transducers' defaults."""

    name: str = ""
    description: str = ""
    array: ArraySpec
    sensor: SensorDefaults = Field(default_factory=SensorDefaults)


class ArrayRef(_Model):
    """Use the array of a sensors file (path relative to the scenario file)."""

    file: str


class Sweep(_Model):
    """``start, start + step, ...`` up to ``stop`` inclusive (degrees)."""

    start: float
    stop: float
    step: float = Field(gt=0)

    @model_validator(mode="after")
    def _order(self) -> Sweep:
        if not self.stop >= self.start:
            raise ValueError("sweep needs stop >= start")
        if (self.stop - self.start) / self.step > MAX_STEPS:
            raise ValueError(f"sweep has more than {MAX_STEPS} angles: raise step")
        return self


Angles = float | list[float] | Sweep


class Line(_Model):
    """Locations from ``start`` to ``end`` inclusive: ``count`` of them or ``step`` apart."""

    start: Point
    end: Point
    count: int | None = Field(default=None, ge=1, le=100_000)
    step: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _one(self) -> Line:
        if (self.count is None) == (self.step is None):
            raise ValueError("give exactly one of count and step")
        span = math.dist(self.start, self.end)
        if self.step is not None and span / self.step > MAX_STEPS:
            raise ValueError(f"line has more than {MAX_STEPS} locations: raise step")
        return self


class Route(_Model):
    """Stops every ``step`` metres along ``waypoints``, the robot facing along the route."""

    waypoints: list[Point] = Field(min_length=2)
    step: float = Field(gt=0)

    @model_validator(mode="after")
    def _stops(self) -> Route:
        legs = zip(self.waypoints[:-1], self.waypoints[1:], strict=True)
        length = sum(math.dist(a, b) for a, b in legs)
        if length / self.step > MAX_STEPS:
            raise ValueError(f"route has more than {MAX_STEPS} stops: raise step")
        return self


class PathSpec(_Model):
    """Stops: every location x base heading x turret heading x sensor rotation.

    With ``locations: {waypoints: [...], step: S}`` (a :class:`Route`) the base and the
    turret face along the route, so ``theta_deg`` and ``turret_deg`` must not be given.
    """

    locations: Line | Route | list[Point] = Field(default_factory=lambda: [(0.0, 0.0)])
    theta_deg: Angles = 0.0
    turret_deg: Angles | None = None
    sensor_rotation_deg: Angles | None = None

    @model_validator(mode="after")
    def _route_heading(self) -> PathSpec:
        if isinstance(self.locations, Route) and (
            "theta_deg" in self.model_fields_set or self.turret_deg is not None
        ):
            raise ValueError("a route sets the headings itself: drop theta_deg and turret_deg")
        return self


class TimingSpec(_Model):
    """When sensors fire: one firing every ``firing_interval_s`` from ``start_time``."""

    start_time: float = 0.0
    firing_interval_s: float = Field(default=0.062, gt=0, le=60)


class ImperfectionSpec(_Model):
    """Sensor imperfections (all off by default)."""

    range_noise_sigma: float = Field(default=0.0, ge=0, le=1)
    quantise: bool = False
    quantum: float = Field(default=0.0254, gt=0, le=1)
    dropout_probability: float = Field(default=0.0, ge=0, le=1)
    spurious_probability: float = Field(default=0.0, ge=0, le=1)
    crosstalk: bool = False
    flag_crosstalk: bool = False


class TransducerSpec(_Model):
    """Parameters of ``physics: transducer`` (SI units; see :mod:`sonarsim.transducer`)."""

    beam_model: Literal["gaussian", "piston"] = "gaussian"
    frequency_hz: float = Field(default=49_400.0, gt=1_000, le=1_000_000)
    piston_radius: float = Field(default=0.019, gt=0, le=0.5)
    threshold: float = Field(default=0.014, gt=0, lt=1)
    reference_range: float = Field(default=1.0, gt=0, le=100)
    rise_time_s: float = Field(default=87e-6, ge=0, le=0.01)
    plane_reflectivity: float = Field(default=1.0, gt=0, le=1)
    corner_reflectivity: float = Field(default=1.0, gt=0, le=1)
    edge_reflectivity: float = Field(default=0.05, ge=0, le=1)
    edge_spreading_exponent: float = Field(default=3.0, ge=2, le=6)
    corner_angle_tolerance_deg: float = Field(default=15.0, ge=0, le=45)


Physics = Literal["ideal", "transducer"]


class ScenarioSpec(_Model):
    """A complete simulation scenario.

    Fields: ``world`` (a world YAML path relative to the scenario file, or an inline world
    mapping); ``array`` (``linear``, ``circular``, ``random``, ``explicit``, or
    ``{file: ../sensors/X.yaml}``); ``active`` (ids of the transducers that fire, in
    firing order); ``sensor`` (beam and range of every transducer; for an array file it
    overrides the file's own ``sensor`` block only when given); ``path`` (stops; absent =
    one stop at pose (0, 0, 0, 0)); ``pairs`` (``own``: each transmitter hears itself,
    ``all``: every active transducer at the same stop listens); ``first_echo_only``;
    ``max_order`` (bounces, >1 via mirror images of flat surfaces); ``speed_of_sound``
    (m/s); ``seed`` (every random draw); ``timing``; ``imperfections``;
    ``record_no_echo`` (a flagged row for each channel that heard nothing);
    ``truth_spacing`` (m, <= 0.01); ``physics`` (``ideal``: the paper's specular echoes
    in a hard-edged beam at the exact range; ``transducer``: beam pattern, threshold,
    time walk, corners, edges, see :mod:`sonarsim.transducer`; absent: the world's
    ``physics``, else ``ideal``); ``transducer`` (that physics' parameters).
    """

    name: str = ""
    description: str = ""
    world: str | dict[str, Any]
    sensor: SensorDefaults = Field(default_factory=SensorDefaults)
    array: ArraySpec | ArrayRef
    active: list[int] | None = None
    path: PathSpec | None = None
    pairs: Literal["own", "all"] = "own"
    first_echo_only: bool = False
    max_order: int = Field(default=1, ge=1, le=4)
    speed_of_sound: float = Field(default=343.3, ge=300, le=400)
    seed: int = Field(default=0, ge=0)
    timing: TimingSpec = Field(default_factory=TimingSpec)
    imperfections: ImperfectionSpec = Field(default_factory=ImperfectionSpec)
    record_no_echo: bool = False
    truth_spacing: float = Field(default=0.01, gt=0, le=0.01)
    physics: Physics | None = None
    transducer: TransducerSpec = Field(default_factory=TransducerSpec)
