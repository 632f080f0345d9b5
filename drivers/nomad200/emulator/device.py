"""Assemble an emulated robot (model + link + faults) from user options."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import IO

from nomad200.codec import BAUD_RATES
from nomad200.emulator.clock import Clock, MonotonicClock, VirtualClock
from nomad200.emulator.link import Faults, Link
from nomad200.emulator.model import NomadModel
from nomad200.emulator.sonar import EchoFn, echo_fn_for_world

__all__ = ["EmulatorOptions", "build_link", "load_world_echo"]


@dataclass
class EmulatorOptions:
    """Everything that configures an emulated robot (CLI flags and URL query share it)."""

    world: str | None = None
    baud: int = 9600
    fast: bool = False
    seed: int = 0
    garble: float = 0.0
    drop: float = 0.0
    stall: float = 0.0
    stall_for: float = 2.0
    unplug_at: float | None = None
    unplug_for: float = 2.0
    trace: str | None = None
    garble_rx: float = 0.0
    drop_rx: float = 0.0

    def validate(self) -> None:
        """Raise ValueError with a one-line message for impossible options."""
        if self.baud not in BAUD_RATES:
            allowed = ", ".join(str(b) for b in BAUD_RATES)
            raise ValueError(f"baud {self.baud} is not a Nomad 200 line speed (allowed {allowed})")
        for name in ("garble", "drop", "stall", "garble_rx", "drop_rx"):
            p = getattr(self, name)
            if not (math.isfinite(p) and 0.0 <= p <= 1.0):
                raise ValueError(f"{name} rate must be within 0..1, got {p}")
        if self.stall_for < 0 or self.unplug_for < 0:
            raise ValueError("stall and unplug durations must be >= 0")
        if self.unplug_at is not None and self.unplug_at < 0:
            raise ValueError(f"unplug-at must be >= 0, got {self.unplug_at}")


def load_world_echo(
    path: str | None,
) -> tuple[EchoFn | None, tuple[float, float, float], float | None]:
    """Load a sonarsim world file; return its echo function, start pose and start turret.

    Raises
    ------
    ValueError
        The file is missing or not a valid world (one-line message).
    """
    if path is None:
        return None, (0.0, 0.0, 0.0), None
    try:
        from sonarsim import load_world

        world = load_world(path)
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ValueError(f"cannot load world {path}: {err}") from err
    except Exception as err:  # yaml errors and the like: still a user mistake
        raise ValueError(f"cannot load world {path}: {type(err).__name__}: {err}") from err
    sp = getattr(world, "start_pose", None)
    start = (0.0, 0.0, 0.0) if sp is None else (float(sp[0]), float(sp[1]), float(sp[2]))
    tu = getattr(world, "start_turret", None)
    return echo_fn_for_world(world), start, None if tu is None else float(tu)


def build_link(
    opts: EmulatorOptions, *, clock: Clock | None = None, trace: IO[str] | None = None
) -> Link:
    """A :class:`Link` around a fresh :class:`NomadModel` for ``opts``.

    The clock is virtual in fast mode and real otherwise unless ``clock`` is given.
    """
    opts.validate()
    echo, start, turret = load_world_echo(opts.world)
    if clock is None:
        clock = VirtualClock() if opts.fast else MonotonicClock()
    model = NomadModel(echo=echo, start_pose=start, start_turret=turret, clock=clock, trace=trace)
    faults = Faults(
        garble=opts.garble,
        drop=opts.drop,
        stall=opts.stall,
        stall_s=opts.stall_for,
        seed=opts.seed,
        garble_rx=opts.garble_rx,
        drop_rx=opts.drop_rx,
    )
    return Link(model, baud=opts.baud, faults=faults)
