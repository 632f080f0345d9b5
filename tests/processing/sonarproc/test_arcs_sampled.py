"""Paper-style sampled arcs (``--arc-step``): geometry, sample counts, count map, CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from arcs_api import arc_samples, rasterize_arcs, rasterize_arcs_sampled
from numpy.typing import NDArray
from scipy import ndimage

from sonarproc.arcs import _sampled as arcs_sampled
from sonarproc.arcs import sample_anomalies
from sonarproc.arcs._geometry import arc_geometry
from sonarproc.cli import main
from sonarproc.grid import Grid
from sonarproc.params import RunParams

CELL = 0.01
HALF_DIAG = CELL * math.sqrt(0.5)
Readings = dict[str, NDArray[np.float64]]


def random_readings(seed: int, n: int) -> Readings:
    """Monostatic and bistatic readings around the origin, beams facing +y."""
    rng = np.random.default_rng(seed)
    tx = np.column_stack((rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 0.0, n)))
    bistatic = rng.random(n) < 0.5
    rx = tx + bistatic[:, None] * rng.uniform(-0.3, 0.3, (n, 2))
    c = 0.5 * np.hypot(*(rx - tx).T)
    heading = rng.uniform(0.6, 2.5, n)
    return {
        "tx_xy": tx,
        "tx_heading": heading,
        "rx_xy": rx,
        "rx_heading": heading + rng.uniform(-0.1, 0.1, n),
        "path": 2.0 * c + rng.uniform(2.0, 6.0, n),
        "tx_half_beamwidth": np.full(n, 0.2182),
        "rx_half_beamwidth": np.full(n, 0.2182),
    }


def grid_for(r: Readings) -> Grid:
    return Grid.covering(-6.0, 6.0, -6.0, 6.0, cell=CELL)


def split(r: Readings) -> tuple[tuple[NDArray[np.float64], ...], dict[str, NDArray[np.float64]]]:
    args = (r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"])
    beams = {k: r[k] for k in ("tx_half_beamwidth", "rx_half_beamwidth")}
    return args, beams


def cell_centres(grid: Grid, iy: NDArray[np.intp], ix: NDArray[np.intp]) -> NDArray[np.float64]:
    return np.column_stack((grid.x0 + ix * grid.cell, grid.y0 + iy * grid.cell))


def test_circle_cells_lie_on_the_circle_and_inside_the_beam() -> None:
    grid = Grid.covering(-2.0, 2.0, -2.0, 2.0, cell=CELL)
    arc, iy, ix = arc_samples([[0.1, -0.2]], [1.0], [[0.1, -0.2]], [1.0], [3.0],
                              tx_half_beamwidth=0.4, rx_half_beamwidth=0.4,
                              step_rad=math.radians(0.1), grid=grid)  # fmt: skip
    q = cell_centres(grid, iy, ix) - [0.1, -0.2]
    assert set(arc.tolist()) == {0}
    assert np.abs(np.hypot(*q.T) - 1.5).max() <= HALF_DIAG + 1e-12
    # Within the beam, up to the angle half a cell diagonal subtends at 1.5 m.
    assert np.abs(np.arctan2(q[:, 1], q[:, 0]) - 1.0).max() <= 0.4 + HALF_DIAG / 1.5
    # Fine steps: about one cell per cell of arc length (0.8 rad x 1.5 m = 120 cm).
    assert 120 <= arc.size <= 1.5 * 121


def test_ellipse_cells_lie_on_the_ellipse() -> None:
    r = random_readings(seed=3, n=40)
    grid = grid_for(r)
    args, beams = split(r)
    arc, iy, ix = arc_samples(*args, **beams, step_rad=math.radians(0.05), grid=grid)
    assert np.unique(arc).size > 30
    q = cell_centres(grid, iy, ix)
    focal = np.hypot(*(q - r["tx_xy"][arc]).T) + np.hypot(*(q - r["rx_xy"][arc]).T)
    # |PT| + |PR| changes by at most 2 |dq| when q moves by |dq| <= half a cell diagonal.
    assert np.abs(focal - r["path"][arc]).max() <= 2 * HALF_DIAG + 1e-12
    pairs = arc.astype(np.int64) * grid.nx * grid.ny + iy * grid.nx + ix
    assert np.unique(pairs).size == pairs.size  # one cell per arc, however many samples


def test_coarse_step_one_cell_per_sample() -> None:
    # A circle of radius 2 m, 0.4 rad wide, every 1 deg: samples 3.5 cm apart, 23 cells.
    grid = Grid.covering(-2.5, 2.5, -2.5, 2.5, cell=CELL)
    step = math.radians(1.0)
    arc, _, _ = arc_samples([[0.0, 0.0]], [0.5], [[0.0, 0.0]], [0.5], [4.0],
                            tx_half_beamwidth=0.2, rx_half_beamwidth=0.2, step_rad=step,
                            grid=grid)  # fmt: skip
    assert arc.size == math.floor(0.4 / step) + 1 == 23


@pytest.mark.parametrize("step_deg", [1.0, 2.0, 5.0])
def test_distinct_cells_match_width_over_step(step_deg: float) -> None:
    r = random_readings(seed=11, n=60)
    grid = grid_for(r)
    args, beams = split(r)
    step = math.radians(step_deg)
    geom = arc_geometry(*args, **beams)
    arc, _, _ = arc_samples(*args, **beams, step_rad=step, grid=grid)
    got = np.bincount(arc, minlength=60)[geom.arc]
    width = np.nansum(geom.length, axis=1)
    pieces = np.isfinite(geom.length).sum(axis=1)
    # Samples at least 2 cells apart (b x step) fall in distinct cells: one per sample.
    sparse = geom.b * step >= 2 * CELL
    assert len(geom) > 40 and sparse.sum() > 0.5 * len(geom)
    want = np.floor(width / step + 1e-9).astype(int) + pieces  # per interval floor(l/s) + 1
    assert np.all(np.abs(got[sparse] - want[sparse]) <= pieces[sparse] - 1)
    row, _ = sample_anomalies(geom, step)
    per_row = np.bincount(row, minlength=len(geom))
    np.testing.assert_array_equal(got[sparse], per_row[sparse])


def test_count_map_counts_distinct_arcs_per_cell() -> None:
    grid = Grid.covering(-1.2, 1.2, -1.2, 1.2, cell=CELL)
    one: dict[str, Any] = {"tx_half_beamwidth": 0.3, "rx_half_beamwidth": 0.3, "grid": grid}
    # A very fine step: many samples per cell, still one count per arc.
    fine = rasterize_arcs_sampled([[0, 0]], [1.5], [[0, 0]], [1.5], [2.0], step_rad=1e-4, **one)
    assert fine.max() == 1 and fine.dtype == np.uint32
    # Finely sampled, an arc takes the cells a connected chain takes, plus some corner
    # cells (a dense sample path is 4-connected), none more than a cell away.
    chain = rasterize_arcs([[0, 0]], [1.5], [[0, 0]], [1.5], [2.0], **one)
    assert chain.sum() <= fine.sum() <= 1.5 * chain.sum()
    assert not (fine & ~ndimage.binary_dilation(chain > 0, np.ones((3, 3)))).any()
    # The same reading twice: every cell of it counts 2.
    twice = rasterize_arcs_sampled([[0, 0], [0, 0]], [1.5, 1.5], [[0, 0], [0, 0]], [1.5, 1.5],
                                   [2.0, 2.0], step_rad=0.03, **one)  # fmt: skip
    single = rasterize_arcs_sampled([[0, 0]], [1.5], [[0, 0]], [1.5], [2.0], step_rad=0.03, **one)
    np.testing.assert_array_equal(twice, 2 * single)
    assert int(single.sum()) == single.max() * 21 == 21  # 0.6 rad / 0.03 rad + 1, 3 cm apart


def test_count_map_equals_arc_cells_and_batches_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    r = random_readings(seed=5, n=80)
    grid = grid_for(r)
    args, beams = split(r)
    step = math.radians(0.5)
    counts = rasterize_arcs_sampled(*args, **beams, step_rad=step, grid=grid)
    _, iy, ix = arc_samples(*args, **beams, step_rad=step, grid=grid)
    want = np.zeros(grid.shape, dtype=np.int64)
    np.add.at(want, (iy, ix), 1)
    np.testing.assert_array_equal(counts, want)
    monkeypatch.setattr(arcs_sampled, "_BATCH", 97)  # many batches of whole arcs
    np.testing.assert_array_equal(
        rasterize_arcs_sampled(*args, **beams, step_rad=step, grid=grid), counts
    )


def test_cells_outside_the_grid_are_dropped() -> None:
    grid = Grid.covering(0.0, 0.5, 0.5, 1.5, cell=CELL)  # only part of the arc
    arc, iy, ix = arc_samples([[0, 0]], [1.57], [[0, 0]], [1.57], [2.0],
                              tx_half_beamwidth=0.5, rx_half_beamwidth=0.5,
                              step_rad=0.01, grid=grid)  # fmt: skip
    assert 0 < arc.size < 101
    assert grid.contains_index(iy, ix).all()


@pytest.mark.parametrize("step", [0.0, -0.1, math.nan, math.inf])
def test_bad_step_is_refused(step: float) -> None:
    grid = Grid.covering(-1.0, 1.0, -1.0, 1.0, cell=CELL)
    with pytest.raises(ValueError, match="arc step must be > 0"):
        arc_samples([[0, 0]], [0.0], [[0, 0]], [0.0], [1.0], tx_half_beamwidth=0.2,
                    rx_half_beamwidth=0.2, step_rad=step, grid=grid)  # fmt: skip
    with pytest.raises(ValueError, match="arc_step: must be > 0"):
        RunParams(arc_step=step)


# --- sonarproc run --arc-step ---------------------------------------------------------

EXAMPLES = Path(__file__).resolve().parents[3] / "configs" / "sensors"
CSV_ARGS = [
    str(EXAMPLES / "example-readings.csv"),
    "--sensors",
    str(EXAMPLES / "example-sensors.yaml"),
    "--truth",
    str(EXAMPLES / "example-truth.csv"),
    "--order",
    "6",
]


def run_json(tmp_path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> dict:
    rc = main(["run", *CSV_ARGS, "--out", str(tmp_path / "rep"), "--json", *extra])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc: dict = json.loads(captured.out)
    assert json.loads((tmp_path / "rep" / "report.json").read_text()) == doc
    return doc


def test_cli_arc_step_round_trip(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    connected = run_json(tmp_path / "a", capsys)
    sampled = run_json(tmp_path / "b", capsys, "--arc-step", "2")
    assert connected["parameters"]["arc_step"] is None
    assert sampled["parameters"]["arc_step"] == pytest.approx(math.radians(2.0), rel=1e-12)
    # Same readings and grid; 2 deg samples leave gaps, so fewer arc cells.
    assert sampled["counts"]["readings_used"] == connected["counts"]["readings_used"]
    assert sampled["grid"] == connected["grid"]
    assert 0 < sampled["counts"]["arc_cells"] < 0.8 * connected["counts"]["arc_cells"]


@pytest.mark.parametrize("value", ["0", "-1", "nan"])
def test_cli_arc_step_must_be_positive(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    rc = main(["run", *CSV_ARGS, "--out", str(tmp_path / "rep"), f"--arc-step={value}"])
    err = capsys.readouterr().err
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sonarproc: error: --arc-step: must be > 0")
    assert not (tmp_path / "rep").exists()


def test_reproduce_renders_the_sampled_section() -> None:
    from sonarmorph_tools.reproduce import PAPER, TABLE1, Outcome, SampledRow, render_markdown

    def out(f_c: float) -> Outcome:
        return Outcome(0.1, f_c, 2.0, 0.1, 0.01, 100, True)

    fig02 = SampledRow("fig02 (Fig. 4)", PAPER["fig02"], out(0.9), (out(0.8), out(0.5), out(0.25)),
                       (400, 300, 200, 100))  # fmt: skip
    t1 = [SampledRow(p.figure, p, out(1.0 - 0.1 * i), (out(0.9 - 0.1 * i), out(0.5), out(0.0)))
          for i, p in enumerate(TABLE1)]  # fmt: skip
    text = render_markdown([("fig02", PAPER["fig02"], out(0.9), "d")], [], cell=0.01,
                           sampled=[fig02], sampled_table1=t1)  # fmt: skip
    assert "## Paper-style sampled arcs, steps 0.5° / 1° / 2°" in text
    assert "| 0.341 / 0.900 / 0.800 / 0.500 / 0.250 | 3.18 / 2.00 / 2.00 / 2.00 / 2.00 |" in text
    assert text.count("400 / 300 / 200 / 100") == 1
    assert "paper 0.924 -> 0.000; connected 1.000 -> 0.300; 0.5° 0.900 -> 0.200;" in text
    assert "Paper-style" not in render_markdown([], [], cell=0.01)
