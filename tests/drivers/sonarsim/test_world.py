"""Surfaces, worlds and their YAML."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from sonarsim import (
    Circle,
    Curve,
    Polyline,
    SmoothPolyline,
    World,
    WorldError,
    load_world,
    polynomial,
    profile,
    room,
    sinusoid,
    wall,
    world_from_dict,
)

ROOT = Path(__file__).resolve().parents[3]

ALL_TYPES = {
    "name": "all",
    "start_pose": {"x": 1.0, "y": -0.5, "theta_deg": 30.0},
    "surfaces": [
        {"type": "room", "x_min": -3, "x_max": 3, "y_min": -2, "y_max": 4},
        {"type": "wall", "start": [0, 2], "end": [1, 2], "name": "w"},
        {"type": "polyline", "points": [[0, 0], [1, 1], [2, 0]], "closed": True},
        {"type": "polynomial", "coefficients": [1.5, 0.0, -0.1], "x_range": [-1.8, 1.8]},
        {"type": "sinusoid", "amplitude": 0.15, "period": 1.25, "offset": 2.0,
         "x_range": [-1, 2], "phase_deg": 90},
        {"type": "profile", "points": [[0, 1.0], [0.5, 1.2], [1.0, 1.1], [1.5, 1.0]]},
        {"type": "circle", "center": [1.0, 2.0], "radius": 0.3, "truth": False},
    ],
}  # fmt: skip


def test_every_surface_type_loads() -> None:
    w = world_from_dict(ALL_TYPES)
    assert w.name == "all"
    assert w.start_pose == pytest.approx((1.0, -0.5, np.deg2rad(30.0)))
    assert w.start_turret is None
    kinds = [type(s) for s in w.surfaces]
    assert kinds == [Polyline, Polyline, Polyline, Curve, Curve, Curve, Circle]
    assert not w.surfaces[0].truth and w.surfaces[1].truth and not w.surfaces[6].truth
    segs = w.segments
    assert np.all(np.hypot(*(segs.b - segs.a).T)[~segs.flat] <= 0.01 + 1e-12)
    assert set(np.unique(segs.surface)) == set(range(7))
    # Sinusoid with phase 90 deg is a cosine.
    assert w.surfaces[4].f(np.array([0.0])) == pytest.approx([2.15])


def test_shipped_worlds_load(tmp_path: Path) -> None:
    files = sorted((ROOT / "configs/worlds").glob("*.yaml"))
    assert {f.stem for f in files} >= {"lab", "paper-curve", "paper-sinusoid"}
    for f in files:
        assert len(load_world(f).segments) > 0


def test_lab_cardboard_is_365_cm_long_and_in_front() -> None:
    w = load_world(ROOT / "configs/worlds/lab.yaml")
    card = next(s for s in w.surfaces if s.name == "cardboard")
    pts = card.sample(0.001)
    assert np.hypot(*np.diff(pts, axis=0).T).sum() == pytest.approx(3.65, abs=0.005)
    assert pts[:, 1].min() > 1.0 and pts[:, 1].max() < 2.0


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ({"surfaces": []}, "surfaces"),
        ({"surfaces": [{"type": "circle", "center": [0, 0], "radius": -1}]}, "radius"),
        ({"surfaces": [{"type": "blob"}]}, "surfaces.0"),
        ({"resolution": 0}, "resolution"),
        ({"surfaces": [{"type": "room", "x_min": 1, "x_max": 0, "y_min": 0, "y_max": 1}]},
         "surfaces.0"),
        ({"surfaces": [{"type": "polynomial", "coefficients": [1], "x_range": [2, 1]}]},
         "x_range"),
        ({"surfaces": [{"type": "profile", "points": [[1, 0], [0, 1]]}]}, "increasing"),
        ({"colour": "red"}, "colour"),
    ],
)  # fmt: skip
def test_bad_world_names_file_and_field(patch: dict[str, object], field: str) -> None:
    data = {"surfaces": [{"type": "wall", "start": [0, 0], "end": [1, 0]}], **patch}
    with pytest.raises(WorldError) as info:
        world_from_dict(data, source="w.yaml")
    msg = str(info.value)
    assert msg.startswith("w.yaml: ") and field in msg and "\n" not in msg


def test_load_world_file_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("surfaces: [unclosed\n")
    with pytest.raises(WorldError, match=r"bad\.yaml: not valid YAML"):
        load_world(bad)
    bad.write_text("- 1\n- 2\n")
    with pytest.raises(WorldError, match="mapping"):
        load_world(bad)
    with pytest.raises(FileNotFoundError):
        load_world(tmp_path / "missing.yaml")


def test_truth_profile_dense_and_sorted_for_curves() -> None:
    w = World([sinusoid(0.15, 1.25, (-1.0, 5.0), offset=2.0), room(-2, 6, -1, 3)])
    t = w.truth_profile(0.01)
    steps = np.hypot(*np.diff(t, axis=0).T)
    assert steps.max() <= 0.01 + 1e-12
    assert np.all(np.diff(t[:, 0]) > 0)
    assert t[0, 0] == pytest.approx(-1.0) and t[-1, 0] == pytest.approx(5.0)
    np.testing.assert_allclose(t[:, 1], 2.0 + 0.15 * np.sin(2 * np.pi * t[:, 0] / 1.25))


def test_polyline_and_circle_samples() -> None:
    pl = wall((0.0, 0.0), (1.0, 0.0))
    s = pl.sample(0.01)
    assert len(s) == 101 and np.allclose(s[-1], [1.0, 0.0])
    c = Circle((1.0, 1.0), 0.5).sample(0.01)
    np.testing.assert_allclose(np.hypot(*(c - 1.0).T), 0.5)
    assert np.hypot(*np.diff(c, axis=0).T).max() <= 0.01


def test_profile_passes_through_its_points() -> None:
    pts = np.array([[0, 1.0], [0.5, 1.2], [1.0, 1.1], [1.5, 1.0]])
    c = profile(pts)
    np.testing.assert_allclose(c.f(pts[:, 0]), pts[:, 1], atol=1e-12)
    two = profile(pts[:2])
    assert two.f(np.array([0.25]))[0] == pytest.approx(1.1)


def test_transformed_world_moves_everything() -> None:
    w = World([polynomial([1.0, 0.2], (0.0, 1.0)), Circle((2.0, 0.0), 0.5)], (1.0, 0.0, 0.0))
    m = w.transformed(np.pi / 2, (1.0, 1.0))
    assert isinstance(m.surfaces[0], SmoothPolyline)
    assert m.start_pose == pytest.approx((1.0, 2.0, np.pi / 2))
    np.testing.assert_allclose(m.surfaces[0].points[0], [0.0, 1.0], atol=1e-12)
    assert m.surfaces[1].center == pytest.approx((1.0, 3.0))


def test_yaml_round_trip_of_docstring_example() -> None:
    from sonarsim import world as world_mod

    doc = world_mod.__doc__ or ""
    block = doc.split("::", 1)[1].split("Every surface", 1)[0]
    w = world_from_dict(yaml.safe_load(block))
    assert w.name == "lab" and len(w.surfaces) == 7
    assert w.start_turret == pytest.approx(np.pi / 2)
