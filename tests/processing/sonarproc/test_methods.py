"""Tests for sonarproc.methods: the registry, each method's geometry and values."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarlog import READING_DTYPE, SENSOR_DTYPE, SonarLog, read_log
from sonarmorph_tools.reproduce import PAPER
from sonarproc.grid import Grid
from sonarproc.methods import METHODS, make_method, parse_method_list, parse_settings
from sonarproc.methods.base import MapMethod, MethodMap
from sonarproc.methods.geometry import axis_points, ray_cells, sector_counts
from sonarproc.methods.line_of_sight import Histogram
from sonarproc.methods.morphological import Morphological
from sonarproc.methods.occupancy import Occupancy, log_odds
from sonarproc.params import RunParams
from sonarproc.pipeline import plan_grid, process, select_beams
from sonarproc.simulate import simulate_to_log

C = 343.3
SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


def wall_log(
    ranges: list[float], xs: list[float], *, pairs: list[tuple[int, int]] | None = None
) -> SonarLog:
    """Sensors at (x, 0) looking up (+y) at a wall y = 1; one reading per (tx, rx)."""
    n = len(xs)
    sens = np.zeros(n, SENSOR_DTYPE)
    sens["id"] = np.arange(n)
    sens["x"] = xs
    sens["half_beamwidth"] = np.deg2rad(12.5)
    sens["min_range"], sens["max_range"] = 0.15, 10.7
    pairs = pairs or [(i, i) for i in range(n)]
    r = np.zeros(len(pairs), READING_DTYPE)
    r["tx"] = [p[0] for p in pairs]
    r["rx"] = [p[1] for p in pairs]
    r["tof"] = np.asarray(ranges) * 2 / C
    r["t"] = np.arange(len(pairs)) * 0.04
    sens["heading"] = np.pi / 2  # robot at the origin, turret heading 0
    attrs = {"format": "sonarlog", "format_version": 1, "speed_of_sound": C, "robot": "t"}
    truth = np.column_stack((np.linspace(-2, 2, 401), np.ones(401)))
    return SonarLog(Path("wall.h5"), attrs, sens, r, truth=truth)


@pytest.fixture(scope="module")
def fig02(tmp_path_factory: pytest.TempPathFactory) -> SonarLog:
    path = tmp_path_factory.mktemp("sim") / "fig02.h5"
    simulate_to_log(SCENARIOS / "fig02.yaml", path)
    return read_log(path)


def test_registry_names_and_options() -> None:
    assert set(METHODS) == {
        "morphological", "arc-vote", "line-of-sight", "histogram", "occupancy",
        "directional-max", "arc-median", "triangulation",
    }  # fmt: skip
    assert all(issubclass(c, MapMethod) and c.name == n for n, c in METHODS.items())
    h = make_method("histogram", threshold="6", increment=4)
    assert h.options == {"increment": 4, "decrement": 1, "cv_max": 15, "threshold": 6}
    assert parse_method_list("histogram,occupancy") == ["histogram", "occupancy"]
    assert parse_settings(["occupancy.select=ridge"]) == {"occupancy": {"select": "ridge"}}


@pytest.mark.parametrize(
    ("name", "opts", "match"),
    [
        ("nope", {}, "must be one of"),
        ("histogram", {"bogus": 1}, "has no option 'bogus'"),
        ("histogram", {"threshold": "x"}, "must be a int"),
        ("histogram", {"threshold": 99}, "threshold"),
        ("occupancy", {"p_occ": 0.4}, "p_occ"),
        ("occupancy", {"select": "max"}, "select"),
        ("morphological", {"ops": "thinning:99"}, "thinning"),
    ],
)
def test_bad_options(name: str, opts: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make_method(name, **opts)  # type: ignore[arg-type]


def test_bad_settings() -> None:
    with pytest.raises(ValueError, match=r"METHOD\.OPTION=VALUE"):
        parse_settings(["occupancy=1"])
    with pytest.raises(ValueError, match="must be one of"):
        parse_method_list("occupancy,foo")


def test_axis_points_normal_incidence_exact() -> None:
    # a sensor's own echo: range 1 straight up; a pair 0.2 m apart: the bisector point
    b = math.hypot(1.0, 0.1)
    tx = np.array([[0.3, 0.0], [-0.1, 0.0]])
    rx = np.array([[0.3, 0.0], [0.1, 0.0]])
    hd = np.full(2, np.pi / 2)
    apex, u, s = axis_points(tx, hd, rx, hd, [2.0, 2 * b])
    np.testing.assert_allclose(apex + s[:, None] * u, [[0.3, 1.0], [0.0, 1.0]], atol=1e-12)
    np.testing.assert_allclose(s, [1.0, 1.0], atol=1e-12)
    # pair headings 60 and 120 deg: the bisector is still straight up from the midpoint
    apex, u, s = axis_points(tx[1:], [np.pi / 3], rx[1:], [2 * np.pi / 3], [2 * b])
    np.testing.assert_allclose(apex + s[:, None] * u, [[0.0, 1.0]], atol=1e-12)
    # a path shorter than the baseline has no ellipse
    assert np.isnan(axis_points(tx[1:], [0.0], rx[1:], [0.0], [0.1])[2][0])


def test_line_of_sight_points_on_a_wall() -> None:
    xs = [-0.5, -0.2, 0.0, 0.3, 0.5]
    lg = wall_log([1.0] * 5, xs)
    res = make_method("line-of-sight").run(lg, RunParams(cell=0.01, order=1))
    np.testing.assert_allclose(np.sort(res.run.points_x), xs, atol=1e-9)
    np.testing.assert_allclose(res.run.points_y, 1.0, atol=1e-9)
    assert res.run.counts["processed_cells"] == 5
    assert res.run.metrics.E1_m is not None and res.run.metrics.E1_m < 1e-6


def test_sector_counts_match_brute_force() -> None:
    rng = np.random.default_rng(7)
    g = Grid(x0=-1.0, y0=-1.0, cell=0.05, nx=41, ny=41)
    n = 40
    apex = rng.uniform(-1, 1, (n, 2))
    head = rng.uniform(-np.pi, np.pi, n)
    half = rng.uniform(0.05, 1.2, n)
    rad = rng.uniform(0.1, 1.5, n)
    got = sector_counts(apex, head, half, rad, g)
    yy, xx = np.meshgrid(g.centres_y(), g.centres_x(), indexing="ij")
    dx = xx[None] - apex[:, 0, None, None]
    dy = yy[None] - apex[:, 1, None, None]
    ang = np.abs((np.arctan2(dy, dx) - head[:, None, None] + np.pi) % (2 * np.pi) - np.pi)
    inside = (np.hypot(dx, dy) <= rad[:, None, None]) & (ang <= half[:, None, None])
    want = inside.sum(axis=0)
    # cell centres on a sector's boundary may go either way: allow a few
    assert np.count_nonzero(got != want) <= 3
    assert int(got.sum()) == pytest.approx(int(want.sum()), abs=3)


def test_ray_cells_excludes_the_echo_cell() -> None:
    g = Grid(x0=0.0, y0=0.0, cell=0.1, nx=20, ny=3)
    counts = ray_cells([[0.0, 0.1]], [[1.0, 0.0]], [1.0], g).reshape(g.shape)
    assert counts[1, :10].tolist() == [1] * 10
    assert counts[1, 10:].sum() == 0 and counts[0].sum() == 0 and counts[2].sum() == 0


def test_occupancy_single_reading_log_odds() -> None:
    lg = wall_log([1.0], [0.0])
    occ = Occupancy(p_occ=0.7, p_free=0.35, band=0.04)
    beams, _ = select_beams(lg, RunParams())
    g = Grid(x0=-0.5, y0=-0.5, cell=0.01, nx=101, ny=201)
    lo = occ.log_odds_map(beams, g)
    l_occ, l_free = math.log(0.7 / 0.3), math.log(0.35 / 0.65)
    assert l_occ == pytest.approx(log_odds(0.7)) and l_free == pytest.approx(-0.6190392)

    def at(x: float, y: float) -> float:
        iy, ix = g.to_index(x, y)
        return float(lo[int(iy), int(ix)])

    assert at(0.0, 0.5) == pytest.approx(l_free)  # inside the range: free
    assert at(0.0, 0.97) == pytest.approx(l_free)  # just before the band
    assert at(0.0, 1.0) == pytest.approx(l_occ)  # at the range: occupied
    assert at(0.0, 1.02) == pytest.approx(l_occ)  # band edge (+band/2)
    assert at(0.0, 1.05) == 0.0  # beyond: unknown
    assert at(0.3, 0.5) == 0.0  # outside the cone (tan 12.5 deg * 0.5 = 0.11)
    assert at(0.1, 0.5) == pytest.approx(l_free)  # inside the cone
    # the occupied band is the arc: its area 2 beta r band over the cell area
    n_occ = int(np.count_nonzero(np.isclose(lo, l_occ)))
    assert n_occ == pytest.approx(2 * np.deg2rad(12.5) * 1.0 * 0.04 / 0.01**2, rel=0.05)
    res = occ.run(lg, RunParams(cell=0.01, order=1))
    assert res.probability is not None
    assert float(res.probability.max()) == pytest.approx(0.7)
    assert float(res.probability.min()) == pytest.approx(0.35)


def test_histogram_certainty_values() -> None:
    # two sensors at x = 0 looking up: one sees the wall at 1 m, the other a ghost at 0.5 m
    lg = wall_log([1.0, 0.5, 1.0], [0.0, 0.0], pairs=[(0, 0), (1, 1), (0, 0)])
    hist = Histogram()
    beams, _ = select_beams(lg, RunParams())
    g = Grid(x0=-0.2, y0=0.0, cell=0.01, nx=41, ny=121)
    cv, hits = hist.certainty(beams, g)
    iy, ix = g.to_index([0.0, 0.0, 0.0], [1.0, 0.5, 0.3])
    # wall: 2 hits x 3 = 6; ghost: 3 - 2 passes = 1; on the axis below: 0 (clipped from -3)
    assert cv[iy, ix].tolist() == [6, 1, 0]
    assert hits[iy, ix].tolist() == [2, 1, 0]
    assert int(np.count_nonzero(cv >= 3)) == 1


def test_template_tail_equals_the_pipeline(fig02: SonarLog) -> None:
    """The shared fit + metrics of MapMethod.run give sonarproc run's numbers."""

    class ViaTemplate(Morphological):
        run = MapMethod.run  # type: ignore[assignment]

    params = RunParams(ops="thinning:3", order=9)
    want = process(fig02, params)
    got = ViaTemplate().run(fig02, params).run
    assert got.grid == want.grid
    assert np.array_equal(got.processed, want.processed)
    a, b = got.metrics.to_json(), want.metrics.to_json()
    assert a == pytest.approx(b)
    assert got.counts == want.counts


E1_BOUND_M = {  # on fig02 (the paper's E1 is 3.18 cm for its method)
    "morphological": 0.08,
    "arc-vote": 0.08,
    "line-of-sight": 0.08,
    "histogram": 0.08,
    "occupancy": 0.06,
    "directional-max": 0.15,  # one vote per arc: sparse on fig02's 20 stops
    "arc-median": 0.08,
    "triangulation": 0.15,  # crossings of nearby readings only: sparse on fig02
}


@pytest.mark.parametrize("name", sorted(METHODS))
def test_each_method_on_fig02(fig02: SonarLog, name: str) -> None:
    p = PAPER["fig02"]
    res = make_method(name).run(fig02, RunParams(ops=p.ops, order=p.order))
    m = res.run.metrics
    assert res.method == name
    assert all(v is not None and math.isfinite(v) for v in (m.e, m.f_c, m.E1_m, m.E2))
    assert m.E1_m is not None and m.E1_m < E1_BOUND_M[name]
    assert 0 < m.f_c <= 1 and m.N > 0
    assert res.run.t_cpu_s > 0
    # every method maps on the very grid sonarproc run uses
    beams, _ = select_beams(fig02, RunParams())
    assert res.run.grid == plan_grid(fig02, RunParams(), beams)


def test_occupancy_ridge_keeps_one_cell_per_column(fig02: SonarLog) -> None:
    res = make_method("occupancy", select="ridge").run(fig02, RunParams(order=9))
    cols = np.count_nonzero(res.run.processed, axis=0)
    assert cols.max() >= 1
    thr = make_method("occupancy").run(fig02, RunParams(order=9))
    assert res.run.counts["processed_cells"] < thr.run.counts["processed_cells"]
    assert np.all(res.run.processed <= thr.run.processed)


def test_method_without_evidence_is_refused(fig02: SonarLog) -> None:
    class Empty(MapMethod):
        name = "empty"

        def build(self, beams, grid, params):  # type: ignore[no-untyped-def]
            z = np.zeros(grid.shape, dtype=np.uint32)
            return MethodMap(z > 0, z)

    with pytest.raises(ValueError, match="left nothing"):
        Empty().run(fig02, RunParams())


def test_bbox_applies_to_every_method(fig02: SonarLog) -> None:
    params = RunParams(bbox=(1.0, 3.0, 3.5, 4.7), order=5)
    for name in ("line-of-sight", "occupancy"):
        res = make_method(name).run(fig02, params)
        assert res.run.grid == Grid.covering(1.0, 3.0, 3.5, 4.7, cell=0.01)
        assert res.run.points_x.min() >= 1.0 - 1e-9 and res.run.points_x.max() <= 3.0 + 1e-9
    with pytest.raises(ValueError, match="no arc touches"):
        make_method("histogram").run(fig02, RunParams(bbox=(-9.0, -8.0, 0.0, 1.0)))


def square_room_log(side: float = 4.0, stops: int = 24) -> SonarLog:
    """A 16-sonar ring at the centre of a square room, turret turning; ranges on the axis."""
    from logbuilders import ring_sensors

    sens = ring_sensors()
    ring = sens["heading"]
    turret = np.repeat(np.linspace(0, np.pi / 8, stops, endpoint=False), 16)
    k = np.tile(np.arange(16), stops)
    h = turret + ring[k]
    px, py = side / 2 + 0.22 * np.cos(h), side / 2 + 0.22 * np.sin(h)
    c, s = np.cos(h), np.sin(h)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 0, (side - px) / c, np.where(c < 0, -px / c, np.inf))
        ty = np.where(s > 0, (side - py) / s, np.where(s < 0, -py / s, np.inf))
    r = np.zeros(k.size, READING_DTYPE)
    r["t"] = np.arange(k.size) * 0.04
    r["tx"] = r["rx"] = k
    r["x"] = r["y"] = side / 2
    r["turret"] = turret
    r["tof"] = 2 * np.minimum(tx, ty) / C
    corners = np.array([[0, 0], [side, 0], [side, side], [0, side], [0, 0]], dtype=float)
    attrs = {"format": "sonarlog", "format_version": 1, "speed_of_sound": C, "robot": "t"}
    return SonarLog(Path("room.h5"), attrs, sens, r, truth=corners)


# Directional maximum and triangulation need arcs from many vantage points; this scan has one.
@pytest.mark.parametrize("name", sorted(set(METHODS) - {"directional-max", "triangulation"}))
def test_polar_fit_in_a_room(name: str) -> None:
    lg = square_room_log()
    res = make_method(name).run(lg, RunParams(cell=0.02, fit="polar", order=12))
    m = res.run.metrics
    assert res.run.fit.kind == "polar" and res.run.centre == pytest.approx((2.0, 2.0))
    assert m.E1_m is not None and math.isfinite(m.E1_m) and m.E1_m < 0.25
    assert m.f_c > 0.2


@settings(max_examples=60, deadline=None)
@given(
    t=st.tuples(st.floats(-2, 2), st.floats(-2, 2)),
    base=st.floats(0.0, 0.5),
    tilt=st.floats(-np.pi, np.pi),
    ht=st.floats(-1.2, 1.2),
    hr=st.floats(-1.2, 1.2),
    extra=st.floats(0.3, 5.0),
)
def test_axis_point_lies_on_the_ellipse_and_the_bisector(
    t: tuple[float, float], base: float, tilt: float, ht: float, hr: float, extra: float
) -> None:
    tx = np.array([t])
    rx = tx + base * np.array([[np.cos(tilt), np.sin(tilt)]])
    path = base + extra  # longer than the baseline: a real ellipse
    head_t, head_r = tilt + np.pi / 2 + ht, tilt + np.pi / 2 + hr
    apex, u, s = axis_points(tx, [head_t], rx, [head_r], [path])
    p = apex[0] + s[0] * u[0]
    assert np.hypot(*(p - tx[0])) + np.hypot(*(p - rx[0])) == pytest.approx(path, rel=1e-9)
    bis = np.array([np.cos(head_t) + np.cos(head_r), np.sin(head_t) + np.sin(head_r)])
    bis /= np.hypot(*bis)
    np.testing.assert_allclose(u[0], bis, atol=1e-9)
    np.testing.assert_allclose(apex[0], 0.5 * (tx[0] + rx[0]), atol=1e-12)
