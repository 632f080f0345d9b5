"""Tests for sonarproc.export and ``sonarproc export``: files parsed back, bytes checked."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from sonarlog import SonarLog, read_log
from sonarproc.cli import main
from sonarproc.export import (
    FREE,
    OCCUPIED,
    PLY_DTYPE,
    UNKNOWN,
    fitted_polylines,
    parse_formats,
    read_pgm,
    read_ply,
    read_ros_map,
    ros_map_image,
    surface_cells,
    write_exports,
)
from sonarproc.methods import MethodResult, make_method
from sonarproc.params import RunParams
from sonarproc.simulate import simulate_to_log

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


@pytest.fixture(scope="module")
def fig02_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("sim") / "fig02.h5"
    simulate_to_log(SCENARIOS / "fig02.yaml", path)
    return path


@pytest.fixture(scope="module")
def fig02(fig02_path: Path) -> SonarLog:
    return read_log(fig02_path)


@pytest.fixture(scope="module")
def occ(fig02: SonarLog) -> MethodResult:
    return make_method("occupancy").run(fig02, RunParams(order=9))


def test_ros_map_bytes_and_round_trip(occ: MethodResult, tmp_path: Path) -> None:
    pgm, yml = write_exports(occ, tmp_path, ["ros-map"])
    g = occ.run.grid
    data = pgm.read_bytes()
    header = f"P5\n{g.nx} {g.ny}\n255\n".encode()
    assert data.startswith(header) and len(data) == len(header) + g.nx * g.ny
    img = ros_map_image(occ)
    assert set(np.unique(img).tolist()) == {OCCUPIED, FREE, UNKNOWN}
    # top row of the file = the highest y row of the grid
    assert data[len(header) : len(header) + g.nx] == img[-1].tobytes()
    meta = yaml.safe_load(yml.read_text())
    assert meta == {
        "image": "occupancy.pgm",
        "mode": "trinary",
        "resolution": pytest.approx(g.cell),
        "origin": [pytest.approx(g.x0 - g.cell / 2), pytest.approx(g.y0 - g.cell / 2), 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    grid, back = read_ros_map(yml)
    assert np.array_equal(back, img)
    assert (grid.nx, grid.ny) == (g.nx, g.ny)
    assert grid.x0 == pytest.approx(g.x0) and grid.y0 == pytest.approx(g.y0)
    # the fitted profile is drawn occupied; elsewhere map_server semantics,
    # occ = (255 - v) / 255, give the method's p(occupied) against the thresholds
    drawn = _drawn(occ)
    assert drawn.sum() >= occ.run.grid.nx // 2 and np.all(back[drawn] == OCCUPIED)
    p = occ.probability
    assert p is not None
    occ_ros = (255 - back.astype(float)) / 255
    assert np.array_equal((occ_ros > 0.65)[~drawn], (p > 0.65)[~drawn])
    assert np.array_equal((occ_ros < 0.196)[~drawn], (p < 0.196)[~drawn])
    # every cell the method kept at p > 0.65 is occupied in the map
    assert np.all(back[occ.run.processed & (p > 0.65)] == OCCUPIED)


def test_ros_map_of_a_binary_method(fig02: SonarLog, tmp_path: Path) -> None:
    res = make_method("line-of-sight").run(fig02, RunParams(order=9))
    _, yml = write_exports(res, tmp_path, ["ros-map"])
    _, back = read_ros_map(yml)
    occupied = res.run.processed | _drawn(res)
    assert np.array_equal(back == OCCUPIED, occupied)
    assert np.all(back[~occupied] == UNKNOWN)


def _drawn(res: MethodResult) -> np.ndarray:
    """The cells the fitted curves pass through, as a mask on the grid."""
    mask = np.zeros(res.run.grid.shape, dtype=bool)
    mask[surface_cells(fitted_polylines(res), res.run.grid)] = True
    return mask


def test_geojson_profile(occ: MethodResult, tmp_path: Path) -> None:
    (path,) = write_exports(occ, tmp_path, ["geojson"])
    doc = json.loads(path.read_text())
    assert doc["type"] == "FeatureCollection"
    (feat,) = doc["features"]
    assert feat["geometry"]["type"] == "LineString"
    xy = np.asarray(feat["geometry"]["coordinates"])
    np.testing.assert_allclose(xy, occ.run.fit.sample(occ.run.grid.cell), atol=1e-6)
    props = feat["properties"]
    assert props["method"] == "occupancy" and props["frame"] == "map" and props["units"] == "m"
    assert props["E1_m"] == pytest.approx(occ.run.metrics.E1_m)


def test_ply_point_cloud(occ: MethodResult, tmp_path: Path) -> None:
    (path,) = write_exports(occ, tmp_path, ["ply"])
    data = path.read_bytes()
    head, _, body = data.partition(b"end_header\n")
    lines = head.decode().splitlines()
    assert lines[:2] == ["ply", "format binary_little_endian 1.0"]
    n = int(next(x for x in lines if x.startswith("element vertex")).split()[-1])
    assert n == occ.run.points_x.size
    assert "element surface_point" in head.decode()
    v = read_ply(path)["vertex"]
    assert v.dtype == PLY_DTYPE and v.size == n
    assert body[: v.nbytes] == v.tobytes()
    order = np.lexsort((v["y"], v["x"]))
    np.testing.assert_allclose(v["x"][order], occ.run.points_x, atol=1e-5)
    np.testing.assert_allclose(v["y"][order], occ.run.points_y, atol=1e-5)
    assert np.all(v["z"] == 0) and np.all(v["evidence"] > 0)


def test_parse_formats_and_pgm_errors(tmp_path: Path) -> None:
    assert parse_formats("ply,ros-map,ply") == ["ply", "ros-map"]
    with pytest.raises(ValueError, match="formats: must be among"):
        parse_formats("ros-map,pcd")
    bad = tmp_path / "bad.pgm"
    bad.write_bytes(b"P2\n1 1\n255\n0")
    with pytest.raises(ValueError, match="PGM"):
        read_pgm(bad)


def test_export_cli(fig02_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "exp"
    args = ["export", str(fig02_path), "--method", "histogram", "--out", str(out)]
    assert main([*args, "--format", "ros-map,geojson,ply", "--set", "histogram.threshold=3"]) == 0
    printed = capsys.readouterr().out.split()
    names = ["histogram.pgm", "histogram.yaml", "histogram.geojson", "histogram.ply"]
    assert [Path(p).name for p in printed] == names
    assert all((out / n).is_file() for n in names)
    for bad, needle in (
        (["--format", "kml"], "--format: must be among"),
        (["--method", "a,b"], "must be one of"),
        (["--method", "occupancy,histogram"], "one method"),
        (["--set", "occupancy.p_occ=2"], "not being run"),
    ):
        assert main([*args, *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("sonarproc: error: ") and needle in err, err
