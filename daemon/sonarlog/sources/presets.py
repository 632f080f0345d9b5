"""Robot presets and sensors YAML files: where each transducer sits and what it can hear.

A *sensors file* comes in one of two shapes, both shipped in ``sonarsim``'s
``data/sensors`` folder and resolvable by name (``pioneer3-dx``):

* a table, the same fields as a sonarlog's ``/sensors`` (SI units, mounts in the turret
  frame, which is the base frame on a robot without a turret)::

      robot: my-rover          # optional
      speed_of_sound: 343.3    # m/s, optional
      sensors:
        - {id: 0, x: 0.15, y: 0.0, heading: 0.0, half_beamwidth: 0.26,
           min_range: 0.02, max_range: 4.0, frame: sonar_front}   # frame optional

  ``frame`` (optional) names the ROS frame or topic of that transducer's
  ``sensor_msgs/Range`` messages;
* an array, as sonarsim's scenarios use (``array: {type: circular, count: 16, ...}`` plus
  a ``sensor`` block of beam and range figures in degrees and metres).

The name ``ring-N`` (or ``ring-N-R``) gives ``N`` sensors evenly spaced on a ring of radius
``R`` metres (default 0.2), looking outward, sensor 0 straight ahead.

>>> s = load_sensors("ring-8")
>>> len(s.table), round(float(s.table["heading"][2]), 4)
(8, 1.5708)
>>> "pioneer3-dx" in preset_names()
True
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from sonarlog.schema import SENSOR_DTYPE
from sonarlog.sources.errors import SourceError

if TYPE_CHECKING:
    from sonarsim.arrays import SensorArray
    from sonarsim.scenario_spec import SensorFile

# sonarsim (the shipped presets, the array shapes) is imported where it is needed: its
# import costs most of a second, and a sensors table read from a file needs none of it

__all__ = ["SensorSet", "load_sensors", "preset_names", "sensors_for"]

_RING = re.compile(r"^ring-(\d{1,3})(?:-(\d+(?:\.\d+)?))?$")
_DEFAULT_RING_RADIUS = 0.2


@dataclass(frozen=True)
class SensorSet:
    """A transducer table and what came with it.

    Attributes
    ----------
    table : numpy.ndarray
        :data:`sonarlog.SENSOR_DTYPE` rows.
    robot : str
        Robot name from the file (may be empty).
    speed_of_sound : float or None
        m/s when the file gives one.
    frames : dict
        Transducer id of each ROS frame or topic name the file names.
    source : str
        Where it came from (``preset pioneer3-dx`` or a file path).
    """

    table: np.ndarray
    robot: str = ""
    speed_of_sound: float | None = None
    frames: dict[str, int] = field(default_factory=dict)
    source: str = ""


class _Sensor(BaseModel):
    model_config = ConfigDict(extra="forbid")

    id: int = Field(ge=-32768, le=32767)
    x: float
    y: float
    heading: float
    half_beamwidth: float = Field(gt=0.0, lt=math.pi)
    min_range: float = Field(ge=0.0)
    max_range: float = Field(gt=0.0)
    frame: str | None = None

    @field_validator("x", "y", "heading")
    @classmethod
    def _finite(cls, v: float) -> float:
        if not math.isfinite(v):
            raise ValueError("must be finite")
        return v

    @model_validator(mode="after")
    def _ranges(self) -> _Sensor:
        if not self.max_range > self.min_range:
            raise ValueError("max_range must be greater than min_range")
        return self


class _TableFile(BaseModel):
    model_config = ConfigDict(extra="forbid")

    robot: str = ""
    speed_of_sound: float | None = Field(default=None, gt=0.0)
    sensors: list[_Sensor] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique(self) -> _TableFile:
        ids = [s.id for s in self.sensors]
        if len(set(ids)) != len(ids):
            raise ValueError(f"sensor id(s) {sorted({i for i in ids if ids.count(i) > 1})} repeat")
        frames = [s.frame for s in self.sensors if s.frame is not None]
        if len(set(frames)) != len(frames):
            raise ValueError("frame names repeat")
        return self


def preset_names() -> list[str]:
    """Names of the shipped sensors files usable as ``robot`` presets, sorted."""
    from sonarsim.shipped import shipped_names

    return shipped_names("sensors")


def _first_error(source: str, err: ValidationError) -> str:
    first = err.errors()[0]
    where = ".".join(str(p) for p in first["loc"]) or "(top level)"
    return f"{source}: {where}: {first['msg']}"


def _limits(spec: SensorFile) -> dict[str, float]:
    return {
        "half_beamwidth": math.radians(spec.sensor.half_beamwidth_deg),
        "min_range": spec.sensor.min_range,
        "max_range": spec.sensor.max_range,
    }


def _array_table(source: str, spec: SensorFile) -> np.ndarray:
    from sonarsim.arrays import circular_array, linear_array, make_array
    from sonarsim.scenario_spec import CircularArray, ExplicitArray, LinearArray

    a = spec.array
    lim = _limits(spec)
    arr: SensorArray
    if isinstance(a, CircularArray):
        step = None if a.step_deg is None else math.radians(a.step_deg)
        arr = circular_array(a.count, a.radius, step=step, **lim)
    elif isinstance(a, LinearArray):
        arr = linear_array(
            a.count, a.spacing, origin=a.origin, direction=math.radians(a.direction_deg),
            heading=math.radians(a.heading_deg), **lim,
        )  # fmt: skip
    elif isinstance(a, ExplicitArray):
        ids = [r.id if r.id is not None else k for k, r in enumerate(a.sensors)]
        arr = make_array(
            [r.x for r in a.sensors], [r.y for r in a.sensors],
            np.radians([r.heading_deg for r in a.sensors]), ids=ids, **lim,
        )  # fmt: skip
    else:
        raise SourceError(f"{source}: array.type {a.type!r} cannot describe a robot's sonars")
    return np.asarray(arr.records()).astype(SENSOR_DTYPE)


def _from_mapping(source: str, doc: dict[str, Any]) -> SensorSet:
    if "sensors" in doc:
        try:
            tf = _TableFile.model_validate(doc)
        except ValidationError as err:
            raise SourceError(_first_error(source, err)) from err
        rows = [tuple(getattr(s, n) for n in SENSOR_DTYPE.names or ()) for s in tf.sensors]
        frames = {s.frame: s.id for s in tf.sensors if s.frame is not None}
        return SensorSet(
            np.array(rows, dtype=SENSOR_DTYPE), tf.robot, tf.speed_of_sound, frames, source
        )
    if "array" in doc:
        from sonarsim.scenario_spec import SensorFile

        try:
            sf = SensorFile.model_validate(doc)
        except ValidationError as err:
            raise SourceError(_first_error(source, err)) from err
        return SensorSet(_array_table(source, sf), sf.name, None, {}, source)
    raise SourceError(f"{source}: a sensors file needs a 'sensors' list or an 'array' mapping")


def _ring(name: str, m: re.Match[str]) -> SensorSet:
    count = int(m.group(1))
    radius = float(m.group(2)) if m.group(2) else _DEFAULT_RING_RADIUS
    if not 1 <= count <= 360 or not radius > 0:
        raise SourceError(f"{name}: a ring needs 1-360 sensors and a positive radius")
    from sonarsim.arrays import circular_array

    arr = circular_array(count, radius, half_beamwidth=math.radians(15.0), min_range=0.02,
                         max_range=4.0)  # fmt: skip
    return SensorSet(
        np.asarray(arr.records()).astype(SENSOR_DTYPE), name, None, {}, f"preset {name}"
    )


def _shipped(ref: str | Path) -> Path:
    """The shipped sensors file ``ref`` names (:func:`sonarsim.shipped.resolve_shipped`)."""
    from sonarsim.shipped import resolve_shipped

    return resolve_shipped(ref, kind="sensors")


def load_sensors(ref: str | Path) -> SensorSet:
    """Load a sensors file, a shipped preset by name, or a ``ring-N[-R]`` ring.

    Parameters
    ----------
    ref : str or Path
        A YAML path, a shipped preset name (see :func:`preset_names`), or ``ring-N[-R]``.

    Returns
    -------
    SensorSet

    Raises
    ------
    SourceError
        Unknown preset, unreadable YAML, or a field out of bounds (one line naming the
        file and the field).
    """
    name = str(ref)
    ring = _RING.match(name)
    if ring and not Path(name).exists():
        return _ring(name, ring)
    try:
        path = Path(name) if Path(name).exists() else _shipped(ref)
    except FileNotFoundError as err:
        raise SourceError(
            f"{name}: no such sensors file and no preset of that name "
            f"(presets: {', '.join(preset_names())}, ring-N, ring-N-R)"
        ) from err
    is_preset = not Path(name).exists()
    source = f"preset {path.stem}" if is_preset else str(path)
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError as err:
        raise SourceError(f"{path}: no such sensors file") from err
    except (OSError, yaml.YAMLError) as err:
        raise SourceError(f"{path}: not a readable YAML file ({str(err).splitlines()[0]})") from err
    if not isinstance(doc, dict):
        raise SourceError(f"{path}: a sensors file must hold a mapping")
    return _from_mapping(source, doc)


def sensors_for(sensors: str | Path | None, robot: str | None) -> SensorSet | None:
    """The sensor set a caller asked for: a sensors YAML wins over a robot preset."""
    if sensors is not None:
        return load_sensors(sensors)
    if robot is not None:
        return load_sensors(robot)
    return None
