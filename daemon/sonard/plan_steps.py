"""The steps of an acquisition plan: one pydantic model per kind of motion.

A plan's ``steps`` list holds these models, told apart by their ``type`` (the key of the
one-key YAML mapping, see :mod:`sonard.plan`). Their bounds are in the YAML units (m, s,
deg, deg/s); :data:`ANGLE_FIELDS` names the fields :func:`sonard.plan.load_plan` converts
to radians, and the error messages use the bounds declared here to say what is allowed.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = [
    "ANGLE_FIELDS",
    "FRONT_SONAR",
    "LEFT_SONAR",
    "MAX_SPEED",
    "MAX_TURN_DEG",
    "RIGHT_SONAR",
    "STEP_MODELS",
    "DefinePose",
    "Dwell",
    "Goto",
    "Rotate",
    "Step",
    "Translate",
    "TurretSweep",
    "WallFollow",
    "Zero",
]

#: physical limits of the Nomad 200 (translation 0.6 m/s, rotation 60 deg/s)
MAX_SPEED = 0.6
MAX_TURN_DEG = 60.0
#: where the side sonars look, relative to the turret heading
LEFT_SONAR = 4
RIGHT_SONAR = 12
FRONT_SONAR = 0


class _Step(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Zero(_Step):
    """ZR: align steering and turret with the bumper zero; pose becomes (0, 0, 0, 0)."""

    type: Literal["zero"] = "zero"


class DefinePose(_Step):
    """DP + DA: declare where the robot stands (x, y in m; theta, turret in rad on load)."""

    type: Literal["define_pose"] = "define_pose"
    x: float = Field(0.0, ge=-80.0, le=80.0)
    y: float = Field(0.0, ge=-80.0, le=80.0)
    theta: float = Field(0.0, ge=-360.0, le=360.0, description="base heading, deg in YAML")
    turret: float | None = Field(
        None, ge=-360.0, le=360.0, description="turret heading in the world, deg; default theta"
    )


class Translate(_Step):
    """Drive along the base heading; stop-and-fire every ``step`` metres or continuously."""

    type: Literal["translate"] = "translate"
    distance: float = Field(ge=-20.0, le=20.0)
    step: float | None = Field(None, ge=0.005, le=5.0)
    speed: float = Field(0.1, ge=0.01, le=MAX_SPEED)
    mode: Literal["stop-and-fire", "continuous"] = "stop-and-fire"
    cycles: int = Field(1, ge=1, le=100, description="firing cycles at each stop")

    @model_validator(mode="after")
    def _step_needed(self) -> Translate:
        if self.mode == "stop-and-fire" and self.step is None:
            raise ValueError("step: required for mode stop-and-fire (0.005 to 5.0 m)")
        return self


class Rotate(_Step):
    """Rotate the base in place by ``angle`` (rad on load); the turret turns with it."""

    type: Literal["rotate"] = "rotate"
    angle: float = Field(ge=-720.0, le=720.0)
    speed: float = Field(30.0, ge=1.0, le=MAX_TURN_DEG, description="deg/s in YAML")
    turret: Literal["follow", "hold"] = "follow"


class TurretSweep(_Step):
    """Turret to ``from``, then by ``step`` to ``to``, firing at each stop (Fig. 20).

    With ``relative`` (default) the angles count from the turret heading when the step
    starts (the direction the sonars face); otherwise they are world headings.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)
    type: Literal["turret_sweep"] = "turret_sweep"
    from_: float = Field(alias="from", ge=-360.0, le=360.0)
    to: float = Field(ge=-360.0, le=360.0)
    step: float = Field(ge=0.1, le=180.0)
    speed: float = Field(30.0, ge=1.0, le=MAX_TURN_DEG)
    relative: bool = Field(True, description="angles relative to the turret heading at start")
    cycles: int = Field(1, ge=1, le=100)


class Goto(_Step):
    """Turn towards (x, y), drive there, then optionally turn to ``theta``."""

    type: Literal["goto"] = "goto"
    x: float = Field(ge=-80.0, le=80.0)
    y: float = Field(ge=-80.0, le=80.0)
    theta: float | None = Field(None, ge=-360.0, le=360.0)
    speed: float = Field(0.1, ge=0.01, le=MAX_SPEED)
    turn_speed: float = Field(30.0, ge=1.0, le=MAX_TURN_DEG)


class Dwell(_Step):
    """Stand still for ``seconds`` while the sonars keep firing."""

    type: Literal["dwell"] = "dwell"
    seconds: float = Field(ge=0.0, le=3600.0)


class WallFollow(_Step):
    """Keep ``distance`` to the wall on ``side`` for ``length`` metres of path (Fig. 21)."""

    type: Literal["wall_follow"] = "wall_follow"
    distance: float = Field(ge=0.3, le=3.0)
    length: float = Field(ge=0.1, le=500.0)
    side: Literal["left", "right"] = "left"
    speed: float = Field(0.1, ge=0.02, le=0.4)
    turn_speed: float = Field(30.0, ge=5.0, le=MAX_TURN_DEG)
    gain: float = Field(2.0, ge=0.1, le=20.0, description="rad/s per metre of distance error")

    @property
    def side_sonar(self) -> int:
        """The sonar looking at the wall (4 on the left, 12 on the right)."""
        return LEFT_SONAR if self.side == "left" else RIGHT_SONAR


Step = Annotated[
    Zero | DefinePose | Translate | Rotate | TurretSweep | Goto | Dwell | WallFollow,
    Field(discriminator="type"),
]

#: fields of each step kind holding angles or angular speeds (deg in YAML, rad once loaded)
ANGLE_FIELDS: dict[str, tuple[str, ...]] = {
    "define_pose": ("theta", "turret"),
    "rotate": ("angle", "speed"),
    "turret_sweep": ("from_", "to", "step", "speed"),
    "goto": ("theta", "turn_speed"),
    "wall_follow": ("turn_speed",),
}


#: the model of each step kind, by its ``type``
STEP_MODELS: dict[str, type[BaseModel]] = {
    m.model_fields["type"].default: m
    for m in (Zero, DefinePose, Translate, Rotate, TurretSweep, Goto, Dwell, WallFollow)
}
