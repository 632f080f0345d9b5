"""Multi-surface scenes with the default ``sonarproc run`` (``--fit auto``): the table.

For each scenario of :data:`SCENARIOS` (simulated with its own seed) and for a Nomad ring
log recorded by a real ``sonard`` process driving the ``wallfollow-ring`` plan through the
emulated lab (:func:`record_ring_log`, seeded), run the default options and tabulate the
readings, the surfaces found, ``precision_m``, ``completeness`` and t_CPU against the
targets :data:`PRECISION_TARGET_M` and :data:`COMPLETENESS_TARGET`.

The ring log's truth is every surface of the lab world, the room's walls included
(:func:`world_truth`); sonard stores none, and a truth CSV holds one polyline only, so
the log is read with :func:`sonarproc.pipeline.load_log` and processed with that truth.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from sonarmorph_tools import TEST_SCENARIOS
from sonarmorph_tools.reproduction.outcome import fmt, table_row
from sonarmorph_tools.reproduction.reflector_score import ReflectorScore, score_reflectors
from sonarproc.errors import SonarprocError
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, load_log, process, run_file

__all__ = [
    "COMPLETENESS_TARGET",
    "FIRST_ORDER",
    "HELD_OUT",
    "PRECISION_TARGET_M",
    "RING_NAME",
    "RING_PLAN",
    "RING_SEED",
    "RING_WORLD",
    "SCENARIOS",
    "TEST_SEEN",
    "RingLogError",
    "SurfaceRow",
    "multi_surface_section",
    "record_ring_log",
    "ring_url",
    "run_multi_surface",
    "world_truth",
]

#: The shipped multi-surface scenarios.
SCENARIOS: tuple[str, ...] = (
    "corridor-l", "room-box", "hall-pillar",
    "office-door", "corridor-tee", "curved-room", "pioneer-hall",
)  # fmt: skip
#: Transducer-physics scenes of the test data that rules have since been developed on:
#: held out once, judged once, and seen from then on.
TEST_SEEN: tuple[str, ...] = (
    "heldout-l-office", "heldout-cross-corridor", "heldout-pillars-diagonal", "heldout-u-hall",
    "heldout2-oblique-office", "heldout2-bend-corridor", "heldout2-curved-hall",
    "heldout3-two-door-room", "heldout3-recess-junction", "heldout3-lbox-hall",
    "heldout4-entry-room", "heldout4-facing-doors", "heldout4-column-alcove",
    "heldout5-stepped-wall", "heldout5-rotated-room", "heldout5-pier-diagonal",
    "heldout6-plus-hall", "heldout6-end-door", "heldout6-slant-office",
    "sparse10-door-corridor", "sparse10-hall-loop", "sparse10-junction",
    "sparse10-l-corridor", "sparse10-return-corridor",
    "sparse10-heldout-cross", "sparse10-heldout-office", "sparse10-heldout-dogleg",
    "heldout7-dogleg-corridor", "heldout7-box-hall", "heldout7-tee-doors",
    "sparse11-heldout-tee", "sparse11-heldout-room-door", "sparse11-heldout-wide-cross",
    "sparse12-heldout-lab", "sparse12-heldout-side-rooms", "sparse12-heldout-alcove-hall",
    "sparse13-heldout-obtuse-room", "sparse13-heldout-alcove-corridor", "sparse13-heldout-l-doors",
    "sparse14-heldout-storeroom", "sparse14-heldout-lobby", "sparse14-heldout-zigzag-corridor",
    "sparse15-heldout-niches", "sparse15-heldout-bay-office", "sparse15-heldout-dead-ends",
    "sparse16-heldout-bent-corridor", "sparse16-heldout-pillar-hall",
    "sparse16-heldout-cluttered-office",
    "sparse17-heldout-workshop", "sparse17-heldout-branch-corridor",
    "sparse17-heldout-curved-lounge",
)  # fmt: skip
#: Transducer-physics scenes of the test data, written before the rules they judge were
#: changed and run only to judge them.
HELD_OUT: tuple[str, ...] = (
    "sparse18-heldout-copy-room", "sparse18-heldout-jog-corridor",
    "sparse18-heldout-slanted-store",
)  # fmt: skip
#: Transducer-physics targets: precision (m), completeness, share of output far (> 10 cm)
#: from every true surface.
PHYSICS_TARGETS = (0.02, 0.85, 0.03)
#: Mean distance from the fitted surfaces to the truth must be at most this (m)...
PRECISION_TARGET_M = 0.03
#: ... and this fraction of the truth the sonars saw must lie within 5 cm of a surface.
COMPLETENESS_TARGET = 0.8
RING_PLAN = "wallfollow-ring"
#: The ring log's name in the table.
RING_NAME = "ring log"
#: The echo model of a scenario with ``first_echo_only: true`` and ``max_order: 1``.
FIRST_ORDER = "first echo, max_order 1"
RING_WORLD = "lab"
#: Seed of the emulator (``nomad://?seed=``): its fault generators; fast mode is virtual time.
RING_SEED = 0
#: Longest a ring-log recording may take (s).
RING_TIMEOUT_S = 300.0


class RingLogError(SonarprocError, RuntimeError):
    """``sonard`` could not record the ring log (the message ends with its stderr)."""


@dataclass(frozen=True)
class SurfaceRow:
    """One multi-surface run with the default options."""

    name: str
    description: str
    readings_used: int
    readings_total: int
    surfaces: int
    choice: str
    precision_m: float | None
    completeness: float | None
    t_cpu_s: float
    #: corners, doorways and far output (transducer-physics scenes only)
    reflectors: ReflectorScore | None = None
    #: a held-out scene (:data:`HELD_OUT`)
    held_out: bool = False

    @classmethod
    def of(cls, name: str, description: str, r: RunResult) -> SurfaceRow:
        """The row of a run (``precision_m``, ``completeness``: ``None`` without surfaces)."""
        sm = r.surface_metrics or {}
        return cls(
            name, description, int(r.counts["readings_used"]), int(r.counts["readings_total"]),
            0 if r.surfaces is None else len(r.surfaces.surfaces),
            str((r.auto or {}).get("choice", r.params.fit)),
            sm.get("precision_m"), sm.get("completeness"), r.t_cpu_s,
        )  # fmt: skip

    @property
    def met(self) -> bool:
        """Both targets met."""
        return (
            self.precision_m is not None
            and self.completeness is not None
            and self.precision_m <= PRECISION_TARGET_M
            and self.completeness >= COMPLETENESS_TARGET
        )


def ring_url(seed: int = RING_SEED) -> str:
    """The emulator URL of the ring log.

    Examples
    --------
    >>> ring_url(3)
    'nomad://?world=lab&fast=1&seed=3'
    """
    return f"nomad://?world={RING_WORLD}&fast=1&seed={seed}"


def record_ring_log(out: Path, *, seed: int = RING_SEED) -> None:
    """Record the ring log: ``sonard`` as a process, ``wallfollow-ring`` on the emulated lab.

    The readings (poses, ranges, flags) are the same on every run with the same seed;
    only their host timestamps differ.

    Raises
    ------
    RingLogError
        sonard failed or took longer than :data:`RING_TIMEOUT_S`.
    """
    from sonarsim.shipped import resolve_shipped

    plan = resolve_shipped(RING_PLAN, kind="plans")
    cmd = [sys.executable, "-m", "sonard", "--port", ring_url(seed), "--plan", str(plan),
           "--out", str(out)]  # fmt: skip
    try:
        proc = subprocess.run(
            cmd, capture_output=True, text=True, timeout=RING_TIMEOUT_S, check=False
        )
    except subprocess.TimeoutExpired as err:
        raise RingLogError(f"sonard did not finish the ring log in {RING_TIMEOUT_S:g} s") from err
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["(no output)"]
        raise RingLogError(f"sonard failed with exit code {proc.returncode}: {tail[0]}")


def world_truth(world: str) -> npt.NDArray[np.float64]:
    """Every surface of a sonarsim world (also those it leaves out of its own truth)."""
    from sonarsim import load_world

    w = load_world(world)
    return w.truth_profile(surfaces=range(len(w.surfaces)))


def _echo_text(scenario: Path) -> str:
    import yaml

    data = yaml.safe_load(scenario.read_text(encoding="utf-8")) or {}
    order = int(data.get("max_order", 1))
    if data.get("physics") == "transducer":
        return "transducer physics (first echo above threshold)"
    first = "first echo" if data.get("first_echo_only", False) else "every echo"
    return f"{first}, max_order {order}"


def run_multi_surface(
    scenario_dir: Path, tmp: Path, *, cell: float = 0.01, ring: bool = True,
    only: Sequence[str] | None = None, reports: Path | None = None,
) -> tuple[list[SurfaceRow], list[str]]:  # fmt: skip
    """Every scenario of :data:`SCENARIOS` (and the ring log): rows and their echo models.

    ``reports``: also write each run's report to ``reports/NAME`` (``reports/ring-log``).
    """
    from sonarproc.report import write_report
    from sonarproc.simulate import simulate_to_log
    from sonarsim.scenario import load_scenario

    params = RunParams(cell=cell, fit="auto")
    rows: list[SurfaceRow] = []
    echoes: list[str] = []
    scenes = [(scenario_dir / f"{n}.yaml", False) for n in SCENARIOS]
    scenes += [(TEST_SCENARIOS / f"{n}.yaml", False) for n in TEST_SEEN]
    scenes += [(TEST_SCENARIOS / f"{n}.yaml", True) for n in HELD_OUT]
    for scenario, held_out in scenes:
        name = scenario.stem
        if (only and name not in only) or not scenario.is_file():
            continue
        logpath = tmp / f"{name}-surfaces.h5"
        summary = simulate_to_log(scenario, logpath)
        result = run_file(logpath, params)
        row = SurfaceRow.of(name, f"scenario, seed {summary.seed}", result)
        spec = load_scenario(scenario)
        if spec.physics == "transducer":
            fits = [] if result.surfaces is None else list(result.surfaces.surfaces)
            score = score_reflectors(spec.world, load_log(logpath), fits)
            row = replace(row, reflectors=score, held_out=held_out)
        rows.append(row)
        if reports is not None:
            write_report(result, reports / name)
        echoes.append(_echo_text(scenario))
    if ring:
        logpath = tmp / "ring.h5"
        record_ring_log(logpath)
        cpu0 = time.process_time()
        lg = load_log(logpath)
        result = process(replace(lg, truth=world_truth(RING_WORLD)), params, cpu_start=cpu0)
        rows.append(SurfaceRow.of(RING_NAME, f"sonard, {RING_PLAN}, emulator seed {RING_SEED}",
                                  result))  # fmt: skip
        echoes.append("first echo, up to 2nd-order (emulator)")
        if reports is not None:
            write_report(result, reports / "ring-log")
    return rows, echoes


def multi_surface_section(rows: Sequence[SurfaceRow], echoes: Sequence[str]) -> list[str]:
    """The multi-surface table of ``docs/reproduction.md``."""
    if not rows:
        return []
    met = sum(r.met for r in rows)
    simulated = {e for r, e in zip(rows, echoes, strict=True) if r.name != RING_NAME}
    if simulated <= {FIRST_ORDER}:
        echo_text = (
            "use `max_order: 1`: first echoes only, no multiple reflections (no corner "
            "double bounce)."
        )
    else:
        echo_text = "use the echo models of the column *echoes*."
    lines = [
        "",
        "## Multi-surface scenes with the default `sonarproc run`",
        "",
        "Beyond the paper: scenes with several walls, corners, a box and a pillar, each run "
        "with `sonarproc run LOG` and nothing else (1 cm cells, `thinning:3`, `--fit "
        "auto`: the paper's polynomial where the kept cells are one curve y = f(x), else "
        "a line, arc or spline per surface). The shipped scenarios `corridor-l`, "
        f"`room-box` and `hall-pillar` are simulated with their own seeds and {echo_text} "
        "The ring log is recorded by a real `sonard` process driving the "
        f"`{RING_PLAN}` plan with all 16 sonars through the emulated lab "
        f"(`{ring_url()}`; the emulator's echoes include corners' second-order "
        "reflections); its truth is every surface of the lab world, the room's walls "
        "included. precision: the mean distance from the fitted surfaces to the truth; "
        "completeness: the fraction of the truth the sonars saw that lies within 5 cm of "
        f"a surface. Targets: precision <= {100 * PRECISION_TARGET_M:g} cm and "
        f"completeness >= {COMPLETENESS_TARGET:g}; met by {met} of {len(rows)}.",
        "",
        "| scene | source | echoes | readings (used / all) | fit | surfaces found "
        "| precision cm | completeness | targets met | t_CPU s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r, echo in zip(rows, echoes, strict=True):
        lines.append(table_row([
            f"`{r.name}`" if r.name != RING_NAME else r.name, r.description, echo,
            f"{r.readings_used} / {r.readings_total}", r.choice, str(r.surfaces),
            fmt(None if r.precision_m is None else 100 * r.precision_m, 2),
            fmt(r.completeness, 3), "yes" if r.met else "no", f"{r.t_cpu_s:.2f}",
        ]))  # fmt: skip
    return lines + reflector_section(rows)


def physics_met(r: SurfaceRow) -> bool:
    """Every transducer-physics target met (:data:`PHYSICS_TARGETS`, all corners, all doorways)."""
    s = r.reflectors
    if s is None or r.precision_m is None or r.completeness is None:
        return False
    prec, comp, far = PHYSICS_TARGETS
    every_corner = s.corners_reported == s.corners_in_view
    return (r.precision_m <= prec and r.completeness >= comp and s.far_share <= far
            and every_corner and s.doors_open == s.doors_seen)  # fmt: skip


def reflector_section(rows: Sequence[SurfaceRow]) -> list[str]:
    """The transducer-physics table: far output, corners and doorways, seen and held out."""
    scored = [r for r in rows if r.reflectors is not None]
    if not scored:
        return []
    prec, comp, far = PHYSICS_TARGETS
    lines = [
        "",
        "### Transducer physics: corners, far output and doorways",
        "",
        "The scenes simulated with `physics: transducer` (beam pattern and threshold, time "
        "walk, retro-reflecting corners, diffracting edges), default options. *far*: the "
        "share of the fitted surfaces (sampled every 1 cm, a point reflector one sample) "
        "more than 10 cm from every true surface. *corners*: a true concave corner (a "
        "free-space sector within 15 degrees of 90) is in view when at least 3 distinct "
        "poses had a sensor inside that sector, the vertex inside its nominal beam and "
        "range and a clear line of sight to it, and heard it (a range within 3 cm of the "
        "distance: the first echo above threshold is all a reading reports); k of n in "
        "view are reported as `corner` "
        "within 5 cm; the true corners in view that were missed are listed below the "
        "table, and the right-angled sectors not in view are counted apart (a wall's "
        "solid side is such a sector). *doorways*: a gap 0.5 to 3 m wide between two "
        "convex vertices (jambs or free wall ends) whose walls run on through the gap's "
        "line, with no surface in it; seen through when readings from at least 3 "
        "distinct poses crossed its middle (more than 10 cm from either jamb) along the "
        "beam axis and echoed from more than 5 cm beyond; open when no fitted line or "
        "curve lies on that middle (within 5 cm of the gap's line, between its two "
        "ends). *held out*: scenes written before the surface and reflector rules were "
        f"last changed and run only to judge them. Targets: precision <= {100 * prec:g} cm, "
        f"completeness >= {comp:g}, far <= {100 * far:g} %, every corner in view "
        "reported, every doorway seen through open.",
        "",
        "| scene | set | precision cm | completeness | far > 10 cm % | corners (k of n) "
        "| doorways open (k of n) | targets met |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in sorted(scored, key=lambda r: r.held_out):
        s = r.reflectors
        assert s is not None
        lines.append(table_row([
            f"`{r.name}`", "held out" if r.held_out else "seen",
            fmt(None if r.precision_m is None else 100 * r.precision_m, 2),
            fmt(r.completeness, 3), f"{100 * s.far_share:.1f}",
            f"{s.corners_reported} of {s.corners_in_view} ({s.corners_out_of_view} not in view)",
            f"{s.doors_open} of {s.doors_seen}", "yes" if physics_met(r) else "no",
        ]))  # fmt: skip
    missed = [(r.name, s.missed_corners) for r in scored
              if (s := r.reflectors) is not None and s.missed_corners]  # fmt: skip
    if missed:
        lines += ["", "Corners in view not reported (m):", ""]
        lines += [f"- `{name}`: " + ", ".join(f"({x:g}, {y:g})" for x, y in m)
                  for name, m in missed]  # fmt: skip
    return lines
