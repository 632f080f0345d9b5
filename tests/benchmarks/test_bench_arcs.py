"""Benchmark: arc rasterisation against a single numpy scatter of the same cells.

Run with ./scripts/bench. Prints million arc cells per second and the ratio of our time to
the floor (one ``np.bincount`` of the same flat cell indices, measured in the same run),
the scatter speed a map of this size needs (about 220-280 M cells/s on this kind of machine).

For reference it also prints two other single scatters of the same cells: a fancy
assignment (which sets but cannot count) and ``np.add.at`` into a uint16 map, the scatter
:func:`~sonarproc.arcs.rasterize_arcs` itself runs its blocks through (it is faster than
bincount because it touches a quarter of the memory). "ours / that" is the overhead of
everything but the scatter: geometry, sampling and the repeat check. All are timed in
turns, best of 7, so that a shared machine's load falls on them alike.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from arcs_api import arc_bounds, arc_cells, rasterize_arcs
from benchtiming import best_of, best_of_interleaved
from numpy.typing import NDArray

from sonarproc.grid import Grid

pytestmark = pytest.mark.benchmark

HALF_BEAM = np.deg2rad(12.5)


def _range_to_walls(
    xy: NDArray[np.float64], ang: NDArray[np.float64], room: float
) -> NDArray[np.float64]:
    """Distance from points inside the square [0, room]^2 to its walls along directions."""
    c = np.cos(ang)
    s = np.sin(ang)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (room - xy[:, 0]) / c, np.where(c < 0, -xy[:, 0] / c, np.inf))
        ty = np.where(s > 0, (room - xy[:, 1]) / s, np.where(s < 0, -xy[:, 1] / s, np.inf))
    return np.minimum(tx, ty)


def ring_readings(n: int, *, room: float, seed: int = 0) -> dict[str, NDArray[np.float64]]:
    """Readings of a 16-sonar ring (radius 0.2 m) wandering a square room.

    Each echo comes from the walls along the beam axis (with 1 cm noise); 80 % of the
    readings are a sensor's own echo, 20 % are crosstalk from a neighbour.
    """
    rng = np.random.default_rng(seed)
    base = rng.uniform(0.5, room - 0.5, (n, 2))
    turret = rng.uniform(-np.pi, np.pi, n)
    k = rng.integers(0, 16, n)
    cross = rng.random(n) < 0.2
    ang_t = turret + k * (2 * np.pi / 16)
    ang_r = ang_t + np.where(cross, rng.choice([-1, 1], n), 0) * (2 * np.pi / 16)
    tx = base + 0.2 * np.stack([np.cos(ang_t), np.sin(ang_t)], axis=1)
    rx = base + 0.2 * np.stack([np.cos(ang_r), np.sin(ang_r)], axis=1)
    mid = 0.5 * (ang_t + ang_r)
    d = _range_to_walls(0.5 * (tx + rx), mid, room)
    sep = np.hypot(*(rx - tx).T)
    path = np.sqrt((2 * d) ** 2 + sep**2) + rng.normal(0.0, 0.01, n)
    path = np.maximum(path, sep + 0.01)
    return {
        "tx_xy": tx,
        "tx_heading": ang_t,
        "rx_xy": rx,
        "rx_heading": ang_r,
        "path": path,
        "tx_half_beamwidth": np.full(n, HALF_BEAM),
        "rx_half_beamwidth": np.full(n, HALF_BEAM),
    }


def covering_grid(r: dict[str, NDArray[np.float64]], cell: float = 0.01) -> Grid:
    """The grid a run would use: covering all arcs."""
    return Grid.covering(*arc_bounds(**r), cell=cell)  # type: ignore[arg-type]


def test_bench_arc_rasterisation() -> None:
    r = ring_readings(90_000, room=20.0)
    grid = covering_grid(r)
    geo = {k: r[k] for k in ("tx_xy", "tx_heading", "rx_xy", "rx_heading", "path")}
    beams = {k: r[k] for k in ("tx_half_beamwidth", "rx_half_beamwidth")}

    counts = rasterize_arcs(**geo, **beams, grid=grid)
    ncells = int(counts.sum())
    # The same cells as flat indices, in arc order (built in slices of readings to keep
    # this process's peak memory low for the benchmarks that run after this one).
    parts = []
    for i in range(0, len(r["path"]), 10_000):
        sl = slice(i, i + 10_000)
        _, iy, ix = arc_cells(**{k: v[sl] for k, v in r.items()}, grid=grid)  # type: ignore[arg-type]
        parts.append(iy * grid.nx + ix)
    flat = np.concatenate(parts).astype(np.intp)
    del parts
    assert flat.size == ncells
    size = grid.nx * grid.ny
    # The floor, one scatter of the same cells (bincount), and two other scatters for
    # reference; timed in turns with ours (the machine may be shared).
    scratch = np.zeros(size, dtype=np.uint32)
    acc16 = np.zeros(size, dtype=np.uint16)

    def assign() -> None:
        scratch[flat] = 1

    def add_at() -> None:
        np.add.at(acc16, flat, np.uint16(1))

    t_bincount, t_ours, t_assign, t_add_at = best_of_interleaved(
        [
            lambda: np.bincount(flat, minlength=size),
            lambda: rasterize_arcs(**geo, **beams, grid=grid),
            assign,
            add_at,
        ]
    )
    tracemalloc.start()
    rasterize_arcs(**geo, **beams, grid=grid)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rate = ncells / t_ours / 1e6
    print(
        f"\narc rasterisation: {len(r['path'])} arcs, {ncells / 1e6:.2f} M cells on a "
        f"{grid.ny}x{grid.nx} grid in {t_ours * 1e3:.1f} ms = {rate:.0f} M cells/s "
        f"(peak {peak / 2**20:.0f} MiB traced)\n"
        f"  floor np.bincount of the same cells: {t_bincount * 1e3:.1f} ms = "
        f"{ncells / t_bincount / 1e6:.0f} M cells/s; ours / floor = {t_ours / t_bincount:.2f}x "
        f"(target <= 3x, >= 90 M cells/s)\n"
        f"  (fancy assignment of the same cells: {t_assign * 1e3:.1f} ms = "
        f"{ncells / t_assign / 1e6:.0f} M cells/s; ours / that = {t_ours / t_assign:.2f}x)\n"
        f"  (np.add.at of the same cells into uint16: {t_add_at * 1e3:.1f} ms = "
        f"{ncells / t_add_at / 1e6:.0f} M cells/s; ours / that = {t_ours / t_add_at:.2f}x)"
    )


def test_bench_arc_scaling() -> None:
    """Cost against readings (at 1 cm) and against map area (90 000 readings)."""
    lines = ["\nrasterisation scaling (best of 3):", "  readings   grid         ms    ns/cell"]
    for n in (11_250, 22_500, 45_000, 90_000):
        r = ring_readings(n, room=20.0)
        grid = covering_grid(r)
        cells = int(rasterize_arcs(**r, grid=grid).sum())  # type: ignore[arg-type]
        t = best_of(lambda r=r, grid=grid: rasterize_arcs(**r, grid=grid), repeat=3)  # type: ignore[misc]
        lines.append(f"  {n:8d}   {grid.ny}x{grid.nx}  {t * 1e3:7.1f}  {t / cells * 1e9:6.2f}")
    r = ring_readings(90_000, room=20.0)
    for cell in (0.04, 0.02, 0.01):
        grid = covering_grid(r, cell)
        cells = int(rasterize_arcs(**r, grid=grid).sum())  # type: ignore[arg-type]
        t = best_of(lambda grid=grid: rasterize_arcs(**r, grid=grid), repeat=3)  # type: ignore[misc]
        lines.append(
            f"  {90_000:8d}   {grid.ny}x{grid.nx}  {t * 1e3:7.1f}  {t / cells * 1e9:6.2f}"
            f"   (cell {cell * 100:g} cm)"
        )
    print("\n".join(lines))


def test_bench_arc_bounds() -> None:
    r = ring_readings(90_000, room=20.0)
    t = best_of(lambda: arc_bounds(**r))  # type: ignore[arg-type]
    print(f"\narc_bounds of 90000 readings: {t * 1e3:.1f} ms")
