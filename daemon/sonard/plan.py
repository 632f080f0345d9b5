"""Acquisition plans: YAML in, validated SI objects out.

A plan says which sonars fire and in what order, how fast, over which serial link, and
the motion steps to run. Units in the YAML file are metres, seconds and **degrees** for
angles (``theta``, ``turret``, ``angle``, ``from``, ``to``, ``step`` of a turret sweep,
angular speeds in deg/s); :func:`load_plan` converts every angle to radians, so the objects
it returns hold SI units only (m, s, rad, m/s, rad/s).

Each step is a one-key mapping (``- translate: {distance: 1.5, step: 0.025}``) or a bare
name for steps without parameters (``- zero``); the step models are in
:mod:`sonard.plan_steps`. Errors raise :class:`PlanError` whose
message is one line naming the file, the field and the allowed range.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from nomad200 import BAUD_RATES, BaudRate, ring
from sonard.link import poll_seconds
from sonard.plan_steps import (
    ANGLE_FIELDS,
    FRONT_SONAR,
    STEP_MODELS,
    DefinePose,
    Dwell,
    Goto,
    Rotate,
    Step,
    Translate,
    TurretSweep,
    WallFollow,
    Zero,
)
from sonarlog import speed_of_sound_at
from sonarlog.acoustics import TEMPERATURE_RANGE_C
from sonarsim.shipped import resolve_shipped

__all__ = [
    "BAUD_RATES",
    "DefinePose",
    "Dwell",
    "Goto",
    "Plan",
    "PlanError",
    "Rotate",
    "Step",
    "Translate",
    "TurretSweep",
    "WallFollow",
    "Zero",
    "load_plan",
    "parse_plan",
]

#: the sensor board counts the firing interval in 4 ms ticks (CONF_SN rate byte 1..255)
INTERVAL_TICK_S = 0.004


class PlanError(ValueError):
    """A plan file is missing, unreadable or invalid (a configuration error, exit code 2)."""


class Plan(BaseModel):
    """A validated acquisition plan in SI units (angles in rad once loaded)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = ""
    description: str = ""
    sonars: list[int] = Field(min_length=1, max_length=16, description="firing order, ids 0..15")
    interval: float = Field(0.040, ge=0.004, le=1.02, description="firing interval, s")
    max_range: float = Field(
        6.5,
        ge=0.2,
        le=ring.MAX_RANGE,
        description="farthest echo awaited before the next firing, m",
    )
    force: bool = False
    baud: BaudRate = 9600
    speed_of_sound: float = Field(343.3, ge=300.0, le=400.0)
    temperature_c: float | None = Field(
        None,
        ge=TEMPERATURE_RANGE_C[0],
        le=TEMPERATURE_RANGE_C[1],
        description="air temperature, °C; sets speed_of_sound",
    )
    pose_attachments: bool | Literal["auto"] = "auto"
    watchdog: int = Field(2, ge=0, le=255, description="robot motion watchdog, s (0 = off)")
    fault_timeout_s: float = Field(30.0, ge=0.0, le=86400.0)
    steps: list[Step] = Field(min_length=1)

    @model_validator(mode="before")
    @classmethod
    def _one_speed_source(cls, data: Any) -> Any:
        if isinstance(data, dict) and {"speed_of_sound", "temperature_c"} <= data.keys():
            raise ValueError(
                "temperature_c: give either temperature_c (°C, sets the speed of sound) "
                "or speed_of_sound (m/s), not both"
            )
        return data

    @model_validator(mode="after")
    def _check(self) -> Plan:
        if self.temperature_c is not None:
            # frozen model: set the derived field once, during validation
            object.__setattr__(self, "speed_of_sound", speed_of_sound_at(self.temperature_c))
        for s in self.sonars:
            if not 0 <= s <= 15:
                raise ValueError(f"sonars: id {s} out of range (0 to 15)")
        if len(set(self.sonars)) != len(self.sonars):
            raise ValueError("sonars: each id at most once (0 to 15)")
        ticks = self.interval / INTERVAL_TICK_S
        if abs(ticks - round(ticks)) > 1e-6:
            raise ValueError(
                f"interval: {self.interval} s is not a multiple of 0.004 s (0.004 to 1.02 s)"
            )
        need = self.min_interval
        if self.interval < need - 1e-9 and not self.force:
            raise ValueError(
                f"interval: {self.interval:.3f} s is shorter than the echo travel time for "
                f"max_range {self.max_range} m; minimum {need:.3f} s (or set force: true)"
            )
        if self.pose_attachments is True and not self._link_allows_attachments and not self.force:
            cycle = len(self.sonars) * self.interval
            poll = poll_seconds(len(self.sonars), True, self.baud)
            raise ValueError(
                f"baud: {self.baud} too slow for {len(self.sonars)} sonars with pose "
                f"attachments (a poll takes {poll:.3f} s > firing cycle {cycle:.3f} s); "
                f"allowed: {', '.join(str(b) for b in BAUD_RATES if b > self.baud)}"
            )
        for i, st in enumerate(self.steps):
            if isinstance(st, WallFollow):
                for need_id in (st.side_sonar, FRONT_SONAR):
                    if need_id not in self.sonars:
                        raise ValueError(
                            f"steps.{i}.wall_follow: needs sonar {need_id} in sonars "
                            f"({st.side} wall follow uses sonars {FRONT_SONAR} and "
                            f"{st.side_sonar})"
                        )
        return self

    @property
    def _link_allows_attachments(self) -> bool:
        poll = poll_seconds(len(self.sonars), True, self.baud)
        return poll <= len(self.sonars) * self.interval

    @property
    def use_attachments(self) -> bool:
        """Whether to ask for sonar pose attachments (``auto``: when the link keeps up)."""
        if self.pose_attachments == "auto":
            return self._link_allows_attachments
        return bool(self.pose_attachments)

    @property
    def min_interval(self) -> float:
        """Shortest firing interval (s, whole 4 ms ticks) for echoes from ``max_range``."""
        travel = 2.0 * self.max_range / self.speed_of_sound
        return math.ceil(travel / INTERVAL_TICK_S - 1e-9) * INTERVAL_TICK_S


def _normalise_steps(raw: Any) -> Any:
    """Turn ``{kind: {params}}`` / ``kind`` items into ``{"type": kind, **params}``."""
    if not isinstance(raw, list):
        return raw
    out: list[Any] = []
    for item in raw:
        if isinstance(item, str):
            out.append({"type": item})
        elif isinstance(item, dict) and len(item) == 1 and "type" not in item:
            ((kind, params),) = item.items()
            params = {} if params is None else params
            if isinstance(params, dict):
                out.append({"type": kind, **params})
            else:
                out.append({"type": kind, "_": params})
        else:
            out.append(item)
    return out


def _to_radians(plan: Plan) -> Plan:
    steps: list[Any] = []
    for st in plan.steps:
        fields = ANGLE_FIELDS.get(st.type, ())
        upd = {f: math.radians(v) for f in fields if (v := getattr(st, f)) is not None}
        steps.append(st.model_copy(update=upd))
    return plan.model_copy(update={"steps": steps})


def parse_plan(data: Any, source: str = "<plan>") -> Plan:
    """Validate a plan mapping (YAML units: m, s, deg) and return it in SI units (rad).

    Parameters
    ----------
    data : Any
        The parsed YAML document.
    source : str
        Name used in error messages (the file name).

    Returns
    -------
    Plan
        The validated plan, angles in radians.

    Raises
    ------
    PlanError
        One line: ``<source>: <field>: <problem> (allowed ...)``.
    """
    if not isinstance(data, dict):
        raise PlanError(
            f"{source}: a plan must be a YAML mapping with at least 'sonars' and 'steps'"
        )
    data = dict(data)
    data["steps"] = _normalise_steps(data.get("steps"))
    try:
        plan = Plan.model_validate(data)
    except ValidationError as exc:
        raise PlanError(f"{source}: {_describe(exc.errors(include_url=False)[0])}") from None
    return _to_radians(plan)


def _where(loc: tuple[Any, ...]) -> str:
    """``steps.2.translate.step`` style field path (aliases without pydantic's ``_``)."""
    return ".".join(str(p).rstrip("_") if isinstance(p, str) else str(p) for p in loc)


def _describe(err: Any) -> str:
    loc = tuple(err.get("loc", ()))
    msg = str(err.get("msg", "invalid"))
    if msg.startswith("Value error, "):  # our own checks name their field already
        text = msg[len("Value error, ") :]
        return f"{_where(loc)}.{text}" if loc else text
    where = _where(loc) or "plan"
    return f"{where}: {msg[0].lower() + msg[1:]}{_allowed(loc, err)}"


def _field_info(model: type[BaseModel], name: str) -> Any:
    for fname, f in model.model_fields.items():
        if name in (fname, f.alias):
            return f
    return None


def _allowed(loc: tuple[Any, ...], err: Any) -> str:
    """The allowed values of the field at ``loc``, from the models' declared bounds."""
    if loc and loc[0] == "steps" and (len(loc) <= 2 or err["type"] == "union_tag_invalid"):
        return f" (allowed steps: {', '.join(STEP_MODELS)})"
    model: type[BaseModel] | None = Plan
    name = str(loc[0]) if loc else ""
    if loc and loc[0] == "steps" and len(loc) >= 4:
        model, name = STEP_MODELS.get(str(loc[2])), str(loc[3])
    if model is None:
        return ""
    f = _field_info(model, name)
    if f is None:
        names = [v.alias or k for k, v in model.model_fields.items() if k != "type"]
        return f" (allowed fields: {', '.join(names)})"
    if name == "baud":
        return f" (allowed {', '.join(str(b) for b in BAUD_RATES)})"
    lo = next((m.ge for m in f.metadata if getattr(m, "ge", None) is not None), None)
    hi = next((m.le for m in f.metadata if getattr(m, "le", None) is not None), None)
    if lo is None or hi is None:
        return ""
    kind = model.model_fields["type"].default if "type" in model.model_fields else ""
    unit = ""
    if name.rstrip("_") in (a.rstrip("_") for a in ANGLE_FIELDS.get(kind, ())):
        unit = " deg/s" if "speed" in name else " deg"
    return f" (allowed {lo:g} to {hi:g}{unit})"


def load_plan(path: str | Path) -> Plan:
    """Read and validate a plan file.

    Parameters
    ----------
    path : str or Path
        The YAML plan, or the name of a shipped plan (``translate``).

    Returns
    -------
    Plan
        Validated, in SI units (angles in rad).

    Raises
    ------
    PlanError
        When the file is missing, is not YAML, or fails validation (one-line message).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "p.yaml"
    >>> _ = p.write_text("sonars: [0]\\nsteps:\\n  - dwell: {seconds: 1}\\n")
    >>> load_plan(p).interval
    0.04
    """
    try:
        p = resolve_shipped(path, kind="plans")
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise PlanError(f"{path}: cannot read plan: {exc.strerror or exc}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        raise PlanError(f"{p}:{where} not valid YAML: {getattr(exc, 'problem', exc)}") from None
    return parse_plan(data, str(p))
