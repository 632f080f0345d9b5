"""Free space cuts walls at openings; pieces join only where nothing saw through the gap.

Analytic scenes: a straight wall y = 1 (pieces of it), sensors on y = 0 looking up with a
Polaroid's 12.5 degree half beam, one every 5 cm; a sensor whose foot falls on the wall
ranges the wall (1 m, 5 mm noise), one whose foot falls in an opening ranges the room
behind it (3 m).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sonarproc.surfaces.echoes.openings import end_echo_reach
from sonarproc.surfaces.echoes.refine import refine_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.merge import MERGE_GAP_M, merge_collinear
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import (
    FREE_BEAM_FRACTION,
    FreeCones,
    free_feet,
    viewpoint_ids,
)

CELL = 0.01
HALF_BEAM = math.radians(12.5)
STEP = 0.05  # sensor spacing along the wall (m)
BEHIND = 3.0  # range (m) of a reading that saw through an opening


def _readings(
    walls: list[tuple[float, float]], x0: float, x1: float, seed: int = 0
) -> EchoGeometry:
    """Sensors at y = 0 from x0 to x1 looking up at the pieces ``walls`` of y = 1."""
    rng = np.random.default_rng(seed)
    x = np.arange(x0, x1 + 1e-9, STEP)
    on_wall = np.zeros(x.size, dtype=bool)
    for a, b in walls:
        on_wall |= (x >= a) & (x <= b)
    r = np.where(on_wall, 1.0 + rng.normal(0.0, 0.005, x.size), BEHIND)
    n = x.size
    return EchoGeometry(np.c_[x, np.zeros(n)], np.full(n, math.pi / 2), np.full(n, HALF_BEAM), r)


def _cones(g: EchoGeometry) -> FreeCones:
    return FreeCones.of(g.xy, g.heading, g.half_beam, g.range_m)


def _line(x0: float, x1: float, y: float = 1.0) -> tuple[SurfaceFit, SurfaceCells]:
    u = np.arange(0.0, x1 - x0 + 1e-9, CELL)
    cells = SurfaceCells(x0 + u, y + 0 * u, u, np.ones_like(u), False)
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit)
    return fit, cells


def _spans(fits: list[SurfaceFit]) -> list[tuple[float, float]]:
    return sorted((float(f.polyline[:, 0].min()), float(f.polyline[:, 0].max())) for f in fits)


def test_viewpoints_are_positions_one_inch_apart() -> None:
    ids = viewpoint_ids([[0.0, 0.0], [0.005, 0.003], [0.05, 0.0], [0.05, 0.0]])
    assert ids[0] == ids[1] and ids[2] == ids[3] and ids[0] != ids[2]


def test_a_foot_near_the_beam_edge_is_no_evidence() -> None:
    """A far plane near the nominal beam edge may be below the detection threshold: only
    feet inside FREE_BEAM_FRACTION of the half beam count."""
    inside, edge = 0.9 * FREE_BEAM_FRACTION * HALF_BEAM, 1.1 * FREE_BEAM_FRACTION * HALF_BEAM
    heading = math.pi / 2 + np.array([inside, edge])
    cones = FreeCones.of([[0.0, 0.0], [0.5, 0.0]], heading, [HALF_BEAM] * 2, [3.0, 3.0])
    _, read, along = free_feet([[-1.0, 1.0]], [[2.0, 1.0]], cones, margin=0.03)
    assert read.tolist() == [0]
    np.testing.assert_allclose(along, [1.0])


def test_an_echo_within_the_margin_is_not_free() -> None:
    """A range at the wall's farthest point in the beam, plus less than the margin, is the
    wall's own echo (noise, time walk), not a view through it."""
    far = 1.0 / math.cos(HALF_BEAM)
    cones = FreeCones.of([[0.0, 0.0]] * 2, [math.pi / 2] * 2, [HALF_BEAM] * 2,
                         [far + 0.02, far + 0.04])  # fmt: skip
    _, read, _ = free_feet([[-1.0, 1.0]], [[1.0, 1.0]], cones, margin=0.03)
    assert read.tolist() == [1]


def test_a_doorway_bridged_by_a_fit_is_opened() -> None:
    """Walls 0..1.5 and 2.4..4, a 0.9 m doorway between; a fit bridging it is cut into
    two surfaces whose gap is the door less at most one sensor step."""
    door = (1.5, 2.4)
    echoes = _readings([(0.0, door[0]), (door[1], 4.0)], 0.1, 3.9)
    fit, cells = _line(0.0, 4.0)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    spans = _spans(out)
    assert len(spans) == 2, spans
    (_, end), (start, _) = spans
    assert start - end >= (door[1] - door[0]) - STEP, spans
    assert end <= door[0] + STEP / 2 + CELL and start >= door[1] - STEP / 2 - CELL, spans


def test_a_wall_with_no_opening_stays_whole() -> None:
    echoes = _readings([(0.0, 4.0)], 0.1, 3.9)
    fit, cells = _line(0.0, 4.0)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    assert len(out) == 1 and out[0].length_m >= 3.7


def test_one_stray_long_reading_does_not_cut_a_wall() -> None:
    """One reading (one viewpoint) past the wall is a dropout, not an opening."""
    echoes = _readings([(0.0, 4.0)], 0.1, 3.9)
    r = echoes.range_m.copy()
    r[30] = BEHIND
    echoes = EchoGeometry(echoes.xy, echoes.heading, echoes.half_beam, r)
    fit, cells = _line(0.0, 4.0)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    assert len(out) == 1


def test_silent_readings_open_a_doorway_onto_nothing() -> None:
    """A doorway opening onto nothing in range: the readings facing it heard nothing and
    are only known as silent cones, free to the sensor's largest range."""
    door = (1.5, 2.4)
    every = _readings([(0.0, door[0]), (door[1], 4.0)], 0.1, 3.9)
    heard = every.range_m < BEHIND
    echoes, silent = every.subset(heard), every.subset(~heard)
    silent = EchoGeometry(silent.xy, silent.heading, silent.half_beam,
                          np.full(silent.size, 5.0))  # fmt: skip
    fit, cells = _line(0.0, 4.0)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    assert len(out) == 1  # without them nothing says the door is open
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,), silent=silent)
    assert len(_spans(out)) == 2


def test_a_point_reflectors_readings_open_the_doorway_it_was_heard_through() -> None:
    """A corner behind the doorway answered the readings facing it: they echo from no
    surface and are left out of the refit, but their sound crossed the doorway."""
    door = (1.5, 2.4)
    g = _readings([(0.0, door[0]), (door[1], 4.0)], 0.1, 3.9)
    g = EchoGeometry(g.xy, g.heading, g.half_beam, g.range_m, np.arange(g.size))
    heard_wall = g.range_m < BEHIND
    echoes = g.subset(heard_wall)
    fit, cells = _line(0.0, 4.0)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    assert len(out) == 1  # without them nothing says the door is open
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,), witnesses=g)
    spans = _spans(out)
    assert len(spans) == 2, spans
    (_, end), (start, _) = spans
    assert end <= door[0] + STEP / 2 + CELL and start >= door[1] - STEP / 2 - CELL, spans
    # witnesses without rows cannot be told from the echoes: nothing is added
    plain = EchoGeometry(g.xy, g.heading, g.half_beam, g.range_m)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,), witnesses=plain)
    assert len(out) == 1


def test_an_ends_echo_is_heard_about_a_beams_width_past_it() -> None:
    """The reach of a free end's diffracted echo: within the range tolerance's geometry,
    nothing where even head-on the edge is under the threshold (beyond 1.53 m)."""
    d = np.array([0.3, 0.6, 1.1, 1.5, 1.6, 3.0])
    reach = end_echo_reach(d, HALF_BEAM, 0.03)
    assert np.all(reach >= 0.0)
    assert np.all(reach <= np.sqrt((d + 0.03) ** 2 - d**2) + 1e-12)
    assert np.all(reach[:3] > 0.07) and np.all(reach[:3] < 0.14)
    assert reach[4] == 0.0 and reach[5] == 0.0


def test_a_wall_ends_where_its_end_is_heard_from_past_it() -> None:
    """A wall y = 1 ending at x = 2 (a jamb): sensors whose feet lie past it hear the jamb
    (its echo reads sqrt(1 + u^2), within the tolerance) up to its reach, then see
    through (3 m). The echo feet run on past the end; the cut end comes back to it."""
    x = np.arange(0.1, 3.0, STEP)
    u = x - 2.0
    reach = float(end_echo_reach(1.0, HALF_BEAM, 0.03))
    r = np.where(u <= 0.0, 1.0, np.where(u <= reach, np.hypot(1.0, u), BEHIND))
    n = x.size
    echoes = EchoGeometry(np.c_[x, np.zeros(n)], np.full(n, math.pi / 2), np.full(n, HALF_BEAM), r)
    fit, cells = _line(0.0, 2.3)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL, rounds=(0.03,))
    spans = _spans(out)
    assert len(spans) == 1, spans
    last_echo = float(x[u <= reach].max())
    assert last_echo > 2.05  # the jamb's echoes put feet past the end ...
    assert abs(spans[0][1] - 2.0) <= 0.5 * reach + STEP / 2, spans  # ... the end is back


@pytest.mark.parametrize("gap", [(1.5, 2.1), (1.0, 2.5)])
def test_collinear_pieces_with_an_unseen_gap_join(gap: tuple[float, float]) -> None:
    """Nobody faced the gap (longer than the fixed limit used without readings): one wall."""
    assert gap[1] - gap[0] > MERGE_GAP_M
    echoes = _readings([(0.0, 4.0)], 0.1, gap[0] - 0.3)
    more = _readings([(0.0, 4.0)], gap[1] + 0.3, 3.9, seed=1)
    pieces = [_line(0.0, gap[0]), _line(gap[1], 4.0)]
    fits, cells = [p[0] for p in pieces], [p[1] for p in pieces]
    cones = FreeCones.of(np.r_[echoes.xy, more.xy], np.r_[echoes.heading, more.heading],
                         np.r_[echoes.half_beam, more.half_beam],
                         np.r_[echoes.range_m, more.range_m])  # fmt: skip
    merged, _ = merge_collinear(fits, cells, cell=CELL, cones=cones, margin=0.03)
    assert _spans(merged) == [(0.0, pytest.approx(4.0, abs=CELL))]
    # without readings, only short gaps are bridged
    assert len(merge_collinear(fits, cells, cell=CELL)[0]) == 2


def test_collinear_pieces_with_a_seen_through_gap_stay_two() -> None:
    gap = (1.5, 2.1)
    echoes = _readings([(0.0, gap[0]), (gap[1], 4.0)], 0.1, 3.9)
    pieces = [_line(0.0, gap[0]), _line(gap[1], 4.0)]
    merged, _ = merge_collinear([p[0] for p in pieces], [p[1] for p in pieces], cell=CELL,
                                cones=_cones(echoes), margin=0.03)  # fmt: skip
    assert len(merged) == 2


def test_pieces_offset_beyond_their_fit_uncertainty_stay_two() -> None:
    """Parallel pieces 3 cm apart, each fitted to 1 mm: two walls, not one."""
    echoes = _readings([(0.0, 4.0)], 0.1, 1.2)
    pieces = [_line(0.0, 1.5), _line(2.1, 4.0, y=1.03)]
    merged, _ = merge_collinear([p[0] for p in pieces], [p[1] for p in pieces], cell=CELL,
                                cones=_cones(echoes), margin=0.03)  # fmt: skip
    assert len(merged) == 2


def test_a_standing_sensors_arcs_are_never_a_surface() -> None:
    """A robot standing still, its sensor ranging 1 m while turning through 60 degrees:
    forty readings, one viewpoint. Their arcs make a circle round the sensor; no surface."""
    n = 40
    heading = np.linspace(math.radians(60.0), math.radians(120.0), n)
    echoes = EchoGeometry(np.zeros((n, 2)), heading, np.full(n, HALF_BEAM), np.full(n, 1.0))
    phi = np.linspace(math.radians(55.0), math.radians(125.0), 141)
    x, y = np.cos(phi), np.sin(phi)
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x), np.diff(y)))]
    cells = SurfaceCells(x, y, s, np.ones_like(x), False)
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit) and fit.model == "arc"
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL)
    assert out == []


def test_a_wall_seen_from_two_standing_poses_is_no_surface() -> None:
    """A robot stopping twice, 0.5 m apart, its sensor ranging a wall ten times at each
    stop: twenty readings, echo points half a metre apart, but two viewpoints only."""
    x = np.repeat([0.5, 1.0], 10)
    jitter = np.tile(np.linspace(-0.1, 0.1, 10), 2)
    echoes = EchoGeometry(np.c_[x, np.zeros(20)], math.pi / 2 + jitter, np.full(20, HALF_BEAM),
                          np.full(20, 1.0))  # fmt: skip
    fit, cells = _line(0.0, 2.0)
    assert refine_fits([fit], [cells], echoes, cell=CELL) == ([], [])


def test_a_wall_seen_from_three_viewpoints_is_a_surface() -> None:
    x = np.array([0.5, 1.0, 1.5])
    echoes = EchoGeometry(np.c_[np.repeat(x, 3), np.zeros(9)],
                          np.full(9, math.pi / 2) + np.tile([-0.1, 0.0, 0.1], 3),
                          np.full(9, HALF_BEAM), np.full(9, 1.0))  # fmt: skip
    fit, cells = _line(0.0, 2.0)
    out, _ = refine_fits([fit], [cells], echoes, cell=CELL)
    assert len(out) == 1 and out[0].model == "line"


SCENES = Path(__file__).resolve().parents[4] / "data" / "scenarios"


def _free_stretch(polylines: list[np.ndarray], a: np.ndarray, b: np.ndarray) -> float:
    """Longest stretch (m) of the segment a -> b with no surface point within 5 cm."""
    from scipy.spatial import cKDTree

    u = np.arange(0.0, float(np.hypot(*(b - a))) + 1e-9, CELL)
    pts = a + u[:, None] * (b - a) / np.hypot(*(b - a))
    dist, _ = cKDTree(np.concatenate(polylines)).query(pts)
    runs = np.diff(np.flatnonzero(np.diff(np.r_[0, (dist > 0.05).astype(int), 0])))[::2]
    return float(runs.max()) * CELL if runs.size else 0.0


def _run(scenario: str, tmp_path: Path) -> Any:
    from sonarproc.params import RunParams
    from sonarproc.pipeline import load_log, process
    from sonarproc.simulate import simulate_to_log

    simulate_to_log(scenario, tmp_path / "log.h5")
    res = process(load_log(tmp_path / "log.h5"), RunParams(fit="auto"))
    assert res.surfaces is not None and res.surfaces.surfaces
    return res


def test_room_box_door_onto_nothing_stays_open(tmp_path: Path) -> None:
    """room-box's door (x 3.6 .. 4.5 on y = 4) opens onto nothing in range: only the
    readings that heard nothing show it. Its whole width but one 5 cm stop each side is
    free, and every surface rests on three viewpoints or more."""
    res = _run("room-box", tmp_path)
    free = _free_stretch(res.surfaces.polylines(), np.array([3.6, 4.0]), np.array([4.5, 4.0]))
    assert free >= 0.9 - 2 * STEP, free
    assert all(s.viewpoints is not None and s.viewpoints >= 3 for s in res.surfaces.surfaces)


def test_a_doorway_seen_with_transducer_physics_stays_open(tmp_path: Path) -> None:
    """A corridor passing a 0.9 m doorway 1 m away (tests/data/scenarios). A door jamb
    diffracts: readings whose foot lies up to sqrt(2 d tol) = 0.24 m into the doorway (d
    = 1 m, tol = 3 cm) hear it within the range tolerance of the wall's own echo, so each
    side may reach that far in; the rest stays open."""
    res = _run(str(SCENES / "open-doorway-corridor.yaml"), tmp_path)
    polys = res.surfaces.polylines()
    free = _free_stretch(polys, np.array([3.0, 2.0]), np.array([3.9, 2.0]))
    assert free >= 0.9 - 2 * math.sqrt(2 * 1.0 * 0.03), free
    on_wall = [p for p in polys if np.all(np.abs(p[:, 1] - 2.0) < 0.05)]
    assert any(p[:, 0].max() <= 3.3 for p in on_wall) and any(p[:, 0].min() >= 3.6 for p in on_wall)
