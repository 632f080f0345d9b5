"""The map-based refinement of an applied drift correction (sonarproc.align.refine)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from drift import drifted_readings, looped_scenario, pose_error_rms

from sonarlog import LogWriter, read_log
from sonarproc.align import align_poses
from sonarproc.align.bundle import RANGE_SIGMA_M, WallProblem, lines_start, wall_walk
from sonarproc.align.echoes import EchoRays
from sonarproc.align.graph import odometry_ties
from sonarproc.align.refine import blended_poses, refine_alignment
from sonarproc.align.track import interpolate_offsets, place_nodes, travel
from sonarproc.align.walls import Walls
from sonarproc.cli import main
from sonarproc.pipeline.alignment import align_log


def test_blended_poses_interpolate_the_offsets_on_a_straight_track() -> None:
    rng = np.random.default_rng(5)
    x = np.linspace(0.0, 4.0, 81)
    track = np.column_stack((x, np.full(x.size, 1.0), np.zeros(x.size)))
    u = travel(track[:, 0], track[:, 1], track[:, 2], turn_radius=0.25)
    nodes = place_nodes(u, spacing=1.0, driven=u)
    offsets = rng.normal(0.0, 0.02, (nodes.count, 3))
    offsets[:, 2] = 0.0
    offsets[0] = 0.0
    got = blended_poses(track, nodes, offsets, scale=0.02)
    want = track + interpolate_offsets(offsets, nodes.lo, nodes.w, nodes.w_xy)
    # without turns, the scale cancels between a reading's two nodes (it is at the same
    # fraction of the way from each)
    np.testing.assert_allclose(got, want, atol=1e-12)


def test_blended_poses_turn_the_track_with_a_heading_offset() -> None:
    # one stretch, its end node turned by 0.1 rad: a reading at the end node turns with it
    # and keeps its place; the heading offset is blended by travel
    x = np.linspace(0.0, 1.0, 11)
    track = np.column_stack((x, np.zeros(x.size), np.zeros(x.size)))
    nodes = place_nodes(x, spacing=1.0, driven=x)
    offsets = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.1]])
    got = blended_poses(track, nodes, offsets, scale=0.0)
    np.testing.assert_allclose(got[-1], [1.0, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(got[:, 2], 0.1 * x, atol=1e-12)


def test_a_declined_or_empty_alignment_is_not_refined() -> None:
    from sonarlog import READING_DTYPE, SENSOR_DTYPE

    r = np.zeros(3, READING_DTYPE)
    a = align_poses(r, np.zeros(1, SENSOR_DTYPE))
    ref = refine_alignment(r, np.zeros(1, SENSOR_DTYPE), a)
    assert ref.kept is False and ref.alignment is a


@pytest.mark.slow
def test_the_refinement_restores_the_surfaces_of_a_drifted_transducer_log(tmp_path: Path) -> None:
    """pioneer-hall (transducer physics), seed 7, route driven three times, 2 % drift.

    Measured: the pose graph alone leaves 0.91 cm of pose error and a precision 1.04x the
    drift-free run's; refined, 0.28 cm and 0.75x (margin about 1.5 / 0.75 = 2x). Twice the
    refinement's cost drop is 156, against 93 for the 63 unknowns the walls' echoes
    determine (of 179).
    """
    res = looped_scenario("pioneer-hall", 3, seed=7)
    logs = []
    for label, rows in (("exact", res.readings), ("drift", drifted_readings(res.readings, seed=7))):
        path = tmp_path / f"{label}.h5"
        with LogWriter(path, res.sensors, speed_of_sound=float(res.speed_of_sound),
                       robot="sim", truth=res.truth) as w:  # fmt: skip
            w.append(rows)
        logs.append(read_log(path))
    exact, drifted = logs
    aligned, record = align_log(drifted)
    assert record.applied, record.reason
    assert record.summary["refinement_kept"] is True
    assert record.summary["refinement_cost_drop_x2"] > record.summary["refinement_threshold"]
    truth = exact.readings
    before = pose_error_rms(truth, drifted.readings["x"], drifted.readings["y"])
    after = pose_error_rms(truth, aligned.readings["x"], aligned.readings["y"])
    assert after <= 0.05 * before, (before, after)
    precision = []
    for label in ("exact", "drift"):  # default options, as a user runs them
        out = tmp_path / f"run-{label}"
        args = ["run", str(tmp_path / f"{label}.h5"), "--out", str(out), "--figures", "none"]
        assert main(args) == 0
        doc = json.loads((out / "report.json").read_text())
        precision.append(doc["metrics"]["precision_m"])
    p_free, p_on = precision
    assert doc["alignment"]["summary"]["refinement_kept"] is True
    assert p_on <= 1.5 * p_free, (p_on, p_free)


def test_the_bundle_reads_a_walls_ranges_with_their_time_walk() -> None:
    # a straight track between two walls, 1 m and 4 m away, seen head-on and 5 degrees off
    # the axis: ranges as a threshold receiver reads them (the distance plus the walk of
    # the echo) fit the true walls and poses exactly; the far wall reads millimetres long
    x = np.linspace(0.0, 3.0, 61)
    track = np.column_stack((x, np.zeros(x.size), np.zeros(x.size)))
    u = travel(track[:, 0], track[:, 1], track[:, 2], turn_radius=0.25)
    nodes = place_nodes(u, spacing=1.0, driven=u)
    ties = odometry_ties(track[nodes.at], np.diff(u[nodes.at]), np.zeros(nodes.count - 1),
                         drift_fraction=0.005, heading_drift=1e-3, turn_radius=0.25,
                         position_floor=0.005, heading_floor=1e-3)  # fmt: skip
    n = x.size
    reading = np.tile(np.arange(n), 4)
    off_axis = np.radians(np.repeat([0.0, 5.0, 0.0, -5.0], n))
    heading = np.repeat([0.5 * np.pi, 0.5 * np.pi, -0.5 * np.pi, -0.5 * np.pi], n) + off_axis
    distance = np.repeat([1.0, 1.0, 4.0, 4.0], n)
    half_beam = np.full(reading.size, np.radians(12.5))
    walk = wall_walk(distance, off_axis, half_beam, 343.0)
    assert 1e-4 < walk[0] < 3e-4 and 3e-3 < walk[2 * n] < 4e-3  # 0.2 mm at 1 m, 3.3 mm at 4 m
    # a specular echo comes back along the wall's normal: its range is the distance
    rays = EchoRays(reading, np.zeros((reading.size, 2)), np.zeros(reading.size),
                    heading, distance + walk, half_beam)  # fmt: skip
    wall = np.repeat([0, 0, 1, 1], n)
    phi = np.array([0.5 * np.pi, -0.5 * np.pi])
    walls = Walls(np.arange(reading.size), wall, np.array([[1.5, 1.0], [1.5, -4.0]]), phi,
                  np.abs(off_axis))  # fmt: skip
    prob = WallProblem(nodes, ties, rays, track, walls, speed_of_sound=343.0)
    truth = np.concatenate((np.zeros(prob.n_pose), lines_start(walls)))
    # (the walk is taken at the range read, up to 8 mm longer than the distance: it
    # differs by twice 8 mm / 4 m of itself, 30 um)
    np.testing.assert_allclose(prob.residuals(truth)[prob.first_echo :] * RANGE_SIGMA_M, 0.0,
                               atol=5e-5)  # fmt: skip


@pytest.mark.slow
def test_the_refinement_of_a_drifted_transducer_log_fits_the_ranges_less_their_walk() -> None:
    """office-door (transducer physics), seed 13, route driven twice, 2 % drift.

    Measured: the pose graph leaves 1.67 cm of pose error. With the ranges' time walk left
    in, the refinement leaves 0.80 cm; with it taken out, 0.48 cm (twice the cost drop 158
    against 70 for the 45 unknowns the walls' echoes determine).
    """
    res = looped_scenario("office-door", 2, seed=13)
    truth = res.readings
    drifted = drifted_readings(truth, seed=13)
    c = float(res.speed_of_sound)
    a = align_poses(drifted, res.sensors, speed_of_sound=c)
    graph = pose_error_rms(truth, a.x, a.y)
    ref = refine_alignment(drifted, res.sensors, a, speed_of_sound=c)
    assert ref.kept, ref.summary()
    refined = pose_error_rms(truth, ref.alignment.x, ref.alignment.y)
    assert graph > 0.01 and refined <= 0.4 * graph, (graph, refined)
