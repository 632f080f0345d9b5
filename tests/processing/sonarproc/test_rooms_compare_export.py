"""``compare`` and ``export`` on rooms with default options: every file carries the surfaces.

A room (walls at right angles, a box, a pillar) is no function y = f(x): the default fit
finds its surfaces, and compare's rows and files, the GeoJSON, the ROS map, the PLY and
the rosbag2 markers must all hold them, numbered alike.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from sonarproc.cli import main
from sonarproc.export import read_ply, read_ros_map
from sonarproc.methods import DEFAULT_METHODS
from sonarproc.methods.compare import COLUMNS
from sonarproc.simulate import simulate_to_log

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"
ROOMS = ("room-box", "corridor-l", "hall-pillar")
#: A room's walls, found from a few thousand simulated readings, lie within a few cm of the
#: truth: a mean distance of 5 cm or more would be a wall drawn beside its place.
PRECISION_BOUND_M = 0.05


@pytest.fixture(scope="module", params=ROOMS)
def room(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp(request.param) / f"{request.param}.h5"
    simulate_to_log(SCENARIOS / f"{request.param}.yaml", path, seed=1)
    return path


def test_compare_gives_every_method_precision_and_surfaces(
    room: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cmp"
    assert main(["compare", str(room), "--out", str(out), "--figures", "none"]) == 0
    captured = capsys.readouterr()
    assert "fit failed" not in captured.err
    # the table has the new columns
    for heading in ("precision (cm)", "completeness", "surfaces"):
        assert heading in captured.out
    doc = json.loads((out / "compare.json").read_text())
    rows = {r["method"]: r for r in doc["methods"]}
    assert list(rows) == list(DEFAULT_METHODS)
    with_surfaces = 0
    for name, r in rows.items():
        assert r["fit_ok"] is True, name
        assert 0.0 < r["precision_m"] < PRECISION_BOUND_M or r["surfaces"] == 0, name
        assert r["precision_m"] is not None and 0.0 < r["completeness"] <= 1.0, name
        fit = doc["fits"][name]
        if r["surfaces"]:
            with_surfaces += 1
            assert fit["kind"] == "surfaces" and fit["ok"] is True
            assert fit["count"] == r["surfaces"] == len(fit["surfaces"])
            assert [s["surface"] for s in fit["surfaces"]] == list(range(r["surfaces"]))
            # METHOD/surfaces.csv: one polyline per surface, ids 0..N-1
            with (out / name / "surfaces.csv").open() as fh:
                ids = sorted({int(row["surface"]) for row in csv.DictReader(fh)})
            assert ids == list(range(r["surfaces"]))
            gj = json.loads((out / name / "surfaces.geojson").read_text())
            assert len(gj["features"]) == r["surfaces"]
        else:
            assert not (out / name).exists()
    # a room is several surfaces for (almost) every method
    assert with_surfaces >= len(rows) - 1
    # compare.csv: the old columns first, the new ones appended, a value for every method
    with (out / "compare.csv").open() as fh:
        table = list(csv.reader(fh))
    assert tuple(table[0]) == COLUMNS
    assert table[0][-3:] == ["precision_m", "completeness", "surfaces"]
    assert table[0][:12] == [
        "method", "e", "f_c", "E1_m", "E2", "t_cpu_s", "N", "N_k", "points", "fit_ok",
        "fit_order", "fit",
    ]  # fmt: skip
    for line in table[1:]:
        row = dict(zip(table[0], line, strict=True))
        assert float(row["precision_m"]) == pytest.approx(
            rows[row["method"]]["precision_m"], rel=1e-5
        )
        assert float(row["completeness"]) == pytest.approx(
            rows[row["method"]]["completeness"], rel=1e-5
        )
        assert int(row["surfaces"]) == rows[row["method"]]["surfaces"]


def test_export_carries_the_surfaces(
    room: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rosbags.highlevel import AnyReader

    out = tmp_path / "exp"
    args = ["export", str(room), "--format", "geojson,ros-map,ply,rosbag2", "--out", str(out)]
    assert main(args) == 0
    capsys.readouterr()
    # GeoJSON: one LineString per surface, numbered 0..N-1, with its properties
    doc = json.loads((out / "morphological.geojson").read_text())
    assert "fit_failure" not in doc["properties"]
    feats = doc["features"]
    assert len(feats) >= 4 and doc["properties"]["surfaces"] == len(feats)
    assert {f["geometry"]["type"] for f in feats} == {"LineString"}
    for k, f in enumerate(feats):
        props = f["properties"]
        assert props["surface"] == k
        kinds = {"line": "plane", "arc": "cylinder", "spline": "curve"}
        assert props["kind"] == kinds[props["model"]]
        assert props["length_m"] > 0 and props["rms_m"] >= 0 and props["support"] > 0
    polylines = [np.asarray(f["geometry"]["coordinates"], dtype=np.float64) for f in feats]
    # ROS map: every point of every surface is an occupied pixel
    grid, img = read_ros_map(out / "morphological.yaml")
    for poly in polylines:
        iy, ix = grid.to_index(poly[:, 0], poly[:, 1])
        inside = grid.contains_index(iy, ix)
        assert inside.mean() > 0.9
        assert np.all(img[iy[inside], ix[inside]] == 0)
    # PLY: the header declares the surfaces' points, and they are the polylines'
    header = (out / "morphological.ply").read_bytes().split(b"end_header\n")[0].decode()
    n_points = sum(p.shape[0] for p in polylines)
    assert f"element surface_point {n_points}\n" in header
    assert f"comment {len(polylines)} fitted surface(s)" in header
    sp = read_ply(out / "morphological.ply")["surface_point"]
    assert np.bincount(sp["surface"]).tolist() == [p.shape[0] for p in polylines]
    np.testing.assert_allclose(sp["x"], np.concatenate(polylines)[:, 0], atol=1e-4)
    # rosbag2: one LINE_STRIP marker per surface
    with AnyReader([out / "morphological_rosbag2"]) as reader:
        conns = [c for c in reader.connections if c.topic == "/map/surfaces"]
        (msg,) = [reader.deserialize(d, c.msgtype) for c, _, d in reader.messages(conns)]
    ours = [m for m in msg.markers if m.ns == "surfaces"]
    assert len(ours) == len(polylines)
    for m, poly in zip(ours, polylines, strict=True):
        xy = np.array([(p.x, p.y) for p in m.points])
        np.testing.assert_allclose(xy, poly, atol=1e-5)
