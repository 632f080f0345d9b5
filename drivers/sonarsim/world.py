"""The world: a set of surfaces, their packed segments, and the robot's start pose.

Worlds are described in YAML (``configs/worlds/*.yaml``), lengths in metres and angles in
degrees (keys end in ``_deg``)::

    name: lab
    resolution: 0.01            # sampling step along curved surfaces (m), optional
    start_pose: {x: 0.0, y: 0.0, theta_deg: 90.0, turret_deg: 90.0}   # turret optional
    surfaces:
      - {type: room, x_min: -3, x_max: 3, y_min: -1.5, y_max: 3.5}
      - {type: wall, start: [0, 2], end: [1, 2]}
      - {type: polyline, points: [[0, 0], [1, 1], [2, 0]], closed: false}
      - {type: polynomial, coefficients: [1.5, 0.0, -0.1], x_range: [-1.8, 1.8]}
      - {type: sinusoid, amplitude: 0.15, period: 1.25, offset: 2.0, x_range: [-1, 5]}
      - {type: profile, points: [[0, 1.0], [0.5, 1.2], [1.0, 1.1]]}
      - {type: circle, center: [1.0, 2.0], radius: 0.3}
    physics: transducer         # optional: ideal (default) or transducer

Every surface may have ``name`` and ``truth`` (whether it belongs in a simulation's truth
profile; rooms default to false, everything else to true). ``physics`` is the echo
physics scenarios in this world use unless they set their own (see
:mod:`sonarsim.transducer`); corners and edges are derived from the straight pieces
(:mod:`sonarsim.reflectors`), cylinders are ``circle`` surfaces.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import yaml
from numpy.typing import ArrayLike
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from sonarsim.geometry import FloatArray
from sonarsim.segments import DEFAULT_RESOLUTION, Segments, Surface
from sonarsim.shipped import resolve_shipped
from sonarsim.surfaces import (
    Circle,
    Curve,
    Polyline,
    polynomial,
    profile,
    room,
    sinusoid,
    wall,
)


class WorldError(ValueError):
    """A world description that cannot be used (names the file and the field)."""


@dataclass(frozen=True)
class World:
    """Reflecting surfaces plus where the robot starts.

    Parameters
    ----------
    surfaces : sequence of Surface
        The surfaces (see :mod:`sonarsim.surfaces`).
    start_pose : (x, y, theta)
        Robot base pose at power-on (m, m, rad).
    start_turret : float or None
        Turret heading in the world at power-on (rad); None means equal to ``theta``.
    name : str
        Label.
    resolution : float
        Sampling step along curved surfaces (m).

    Examples
    --------
    >>> from sonarsim.surfaces import wall
    >>> w = World([wall((-1.0, 2.0), (1.0, 2.0))])
    >>> len(w.segments)
    1
    """

    surfaces: Sequence[Surface]
    start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start_turret: float | None = None
    name: str = ""
    resolution: float = DEFAULT_RESOLUTION
    source: str = field(default="", compare=False)
    physics: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "surfaces", tuple(self.surfaces))
        if not self.resolution > 0.0:
            raise ValueError(f"resolution must be > 0, got {self.resolution}")

    @cached_property
    def segments(self) -> Segments:
        """All surfaces' segments, packed (computed once)."""
        return Segments.concat(
            [s.segments(self.resolution).with_surface(i) for i, s in enumerate(self.surfaces)]
        )

    def transformed(self, angle: float, offset: ArrayLike) -> World:
        """The world rotated by ``angle`` (rad) about the origin, then shifted by ``offset``."""
        off = np.asarray(offset, dtype=np.float64)
        x, y, th = self.start_pose
        c, s = np.cos(angle), np.sin(angle)
        start = (float(c * x - s * y + off[0]), float(s * x + c * y + off[1]), th + angle)
        turret = None if self.start_turret is None else self.start_turret + angle
        return World(
            [srf.transformed(angle, off, self.resolution) for srf in self.surfaces],
            start, turret, self.name, self.resolution, self.source, self.physics,
        )  # fmt: skip

    def truth_profile(
        self, spacing: float = DEFAULT_RESOLUTION, surfaces: Sequence[int] | None = None
    ) -> FloatArray:
        """Dense samples ``(N, 2)`` of the truth surfaces.

        Parameters
        ----------
        spacing : float
            Largest distance between consecutive samples (m).
        surfaces : sequence of int, optional
            Surface indices to include; default: those with ``truth`` set.

        Returns
        -------
        ndarray, shape (N, 2)
            Samples in surface order; when every included surface is a curve ``y = f(x)``
            the samples are sorted by x. Otherwise, with several surfaces, each is its own
            polyline and a row of NaN separates them (sonarlog's multi-surface truth).
        """
        idx = (
            [i for i, s in enumerate(self.surfaces) if s.truth]
            if surfaces is None
            else list(surfaces)
        )
        if not idx:
            return np.zeros((0, 2))
        parts = [self.surfaces[i].sample(spacing) for i in idx]
        if all(isinstance(self.surfaces[i], Curve) for i in idx):
            pts = np.concatenate(parts)
            return pts[np.argsort(pts[:, 0], kind="stable")]
        gap = np.full((1, 2), np.nan)
        return np.concatenate([r for k, p in enumerate(parts) for r in ((gap, p) if k else (p,))])


# --- YAML schema ---------------------------------------------------------------------------

Point = tuple[float, float]


class _Base(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    name: str = ""
    truth: bool | None = None


class _Wall(_Base):
    type: Literal["wall"]
    start: Point
    end: Point


class _Polyline(_Base):
    type: Literal["polyline"]
    points: list[Point] = Field(min_length=2)
    closed: bool = False


class _Room(_Base):
    type: Literal["room"]
    x_min: float
    x_max: float
    y_min: float
    y_max: float

    @model_validator(mode="after")
    def _order(self) -> _Room:
        if not (self.x_max > self.x_min and self.y_max > self.y_min):
            raise ValueError("room needs x_min < x_max and y_min < y_max")
        return self


class _Range(_Base):
    x_range: Point

    @model_validator(mode="after")
    def _order(self) -> _Range:
        if not self.x_range[1] > self.x_range[0]:
            raise ValueError("x_range must be [low, high] with low < high")
        return self


class _Polynomial(_Range):
    type: Literal["polynomial"]
    coefficients: list[float] = Field(min_length=1)


class _Sinusoid(_Range):
    type: Literal["sinusoid"]
    amplitude: float
    period: float = Field(gt=0)
    offset: float = 0.0
    phase_deg: float = 0.0


class _Profile(_Base):
    type: Literal["profile"]
    points: list[Point] = Field(min_length=2)


class _Circle(_Base):
    type: Literal["circle"]
    center: Point
    radius: float = Field(gt=0)


_SurfaceSpec = Annotated[
    _Wall | _Polyline | _Room | _Polynomial | _Sinusoid | _Profile | _Circle,
    Field(discriminator="type"),
]


class _StartPose(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    x: float = 0.0
    y: float = 0.0
    theta_deg: float = 0.0
    turret_deg: float | None = None


class WorldSpec(BaseModel):
    """The validated YAML world description."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    name: str = ""
    description: str = ""
    resolution: float = Field(DEFAULT_RESOLUTION, gt=0, le=0.1)
    start_pose: _StartPose = _StartPose()
    surfaces: list[_SurfaceSpec] = Field(min_length=1)
    physics: Literal["ideal", "transducer"] | None = None


def _build_surface(spec: Any) -> Surface:
    truth = spec.truth
    kw: dict[str, Any] = {"name": spec.name}
    if truth is not None:
        kw["truth"] = truth
    if isinstance(spec, _Wall):
        return wall(spec.start, spec.end, **kw)
    if isinstance(spec, _Polyline):
        return Polyline(np.asarray(spec.points, dtype=np.float64), spec.closed, **kw)
    if isinstance(spec, _Room):
        return room(spec.x_min, spec.x_max, spec.y_min, spec.y_max, **kw)
    if isinstance(spec, _Polynomial):
        return polynomial(spec.coefficients, spec.x_range, **kw)
    if isinstance(spec, _Sinusoid):
        return sinusoid(
            spec.amplitude, spec.period, spec.x_range, offset=spec.offset,
            phase=float(np.deg2rad(spec.phase_deg)), **kw,
        )  # fmt: skip
    if isinstance(spec, _Profile):
        return profile(np.asarray(spec.points, dtype=np.float64), **kw)
    assert isinstance(spec, _Circle)
    return Circle(spec.center, spec.radius, **kw)


def _field_path(loc: tuple[Any, ...]) -> tuple[list[str], tuple[str, ...]]:
    """The YAML field path of a pydantic error location, and the union branch it is in.

    Union branches show in ``loc`` as ``tagged-union[...]`` plus the tag, as
    ``function-after[...]`` or as a model's class name; none of those is a field the
    file's author wrote, but together they say which alternative the error is about.
    """
    out: list[str] = []
    branch: list[str] = []
    skip = False
    for part in loc:
        text = str(part)
        if skip:
            skip = False
            branch.append(text)
            continue
        if text.startswith("tagged-union["):
            skip = True
            continue
        if "[" in text or "(" in text or (text[:1].isupper() and text.isidentifier()):
            branch.append(text)
            continue
        out.append(text)
    return out, tuple(branch)


def format_validation_error(source: str, err: ValidationError) -> str:
    """One line: ``source: field.path: problem``, for the problem the author most likely made.

    Of a union's alternatives, the one with the fewest problems is taken to be the one
    the author meant; within it an unknown field (a typo) comes before a missing one,
    with the closest allowed name suggested.
    """
    import difflib
    from collections import Counter

    errors = err.errors(include_url=False)
    found = [(*_field_path(tuple(e["loc"])), e) for e in errors]
    sizes = Counter(branch for _, branch, _ in found)
    best = min(sizes, key=lambda b: (sizes[b], list(sizes).index(b)))
    found = [f for f in found if f[1] == best]
    extra = [f for f in found if f[2]["type"] == "extra_forbidden"]
    path, _, first = (extra or found)[0]
    where = ".".join(path) or "(top level)"
    if first["type"] == "extra_forbidden":
        parent = path[:-1]
        missing = [p[-1] for p, _, e in found if e["type"] == "missing" and p[:-1] == parent]
        close = difflib.get_close_matches(path[-1] if path else "", missing, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return f"{source}: {where}: unknown field{hint}"
    msg = str(first["msg"])
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    return f"{source}: {where}: {msg}"


def world_from_dict(data: Mapping[str, Any], *, source: str = "<world>") -> World:
    """Build a :class:`World` from a parsed YAML mapping.

    Raises
    ------
    WorldError
        Naming ``source`` and the offending field.
    """
    try:
        spec = WorldSpec.model_validate(data)
    except ValidationError as err:
        raise WorldError(format_validation_error(source, err)) from err
    try:
        surfaces = [_build_surface(s) for s in spec.surfaces]
    except ValueError as err:
        raise WorldError(f"{source}: surfaces: {err}") from err
    sp = spec.start_pose
    turret = None if sp.turret_deg is None else float(np.deg2rad(sp.turret_deg))
    return World(
        surfaces, (sp.x, sp.y, float(np.deg2rad(sp.theta_deg))), turret, spec.name,
        spec.resolution, source, spec.physics,
    )  # fmt: skip


def load_yaml_mapping(path: str | Path, what: str) -> dict[str, Any]:
    """Read a YAML file that must hold a mapping; errors name the file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise
    except OSError as err:
        raise WorldError(f"{p}: cannot read {what}: {err.strerror or err}") from err
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise WorldError(f"{p}: not valid YAML: {str(err).splitlines()[0]}") from err
    if not isinstance(data, dict):
        raise WorldError(f"{p}: a {what} file must hold a mapping")
    return data


def load_world(path: str | Path) -> World:
    """Load a world from a YAML file.

    Parameters
    ----------
    path : str or Path
        The YAML file (see the module docstring for the format), or the name of a
        shipped world (``lab``).

    Returns
    -------
    World

    Raises
    ------
    WorldError
        The file is not a valid world (the message names the file and the field).
    FileNotFoundError
        The file does not exist.
    """
    path = resolve_shipped(path, kind="worlds")
    return world_from_dict(load_yaml_mapping(path, "world"), source=str(path))
