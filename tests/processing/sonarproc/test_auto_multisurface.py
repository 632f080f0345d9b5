"""The ``surfaces`` candidate of ``--auto`` stands aside where it finds one curve y(x).

(That it is chosen in a room is tested with ``--auto``'s other tests.)
"""

from __future__ import annotations

import numpy as np

from sonarproc.arcs import rasterize
from sonarproc.auto.multisurface import fitted_surfaces
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MethodMap
from sonarproc.methods.testing import flat_wall_beams
from sonarproc.pipeline.surfacefit import choose_fit


def _ridge_map(beams: Beams, grid: Grid, ghosts: bool) -> MethodMap:
    counts = rasterize(beams.arcs, grid).astype(np.uint32)
    row = int(np.argmax(counts.sum(axis=1)))
    processed = np.zeros(counts.shape, dtype=bool)
    processed[row - 1 : row + 2, counts[row] > 0] = True
    if ghosts:
        # stray blobs between the sensors and the wall, as a noisy bistatic log leaves
        # them (no reading echoes from them): the first decision sees several surfaces
        rng = np.random.default_rng(7)
        for _ in range(120):
            r = int(rng.integers(0, row - 100))
            c = int(rng.integers(0, counts.shape[1] - 8))
            processed[r : r + 3, c : c + 6] = True
    return MethodMap(processed, np.where(processed, np.maximum(counts, 1), 0).astype(np.uint32))


def test_one_wall_among_ghost_cells_is_left_to_the_profile_candidates() -> None:
    beams, _ = flat_wall_beams(120)
    # room below the wall (y = 1 m) for the ghosts, down to behind the sensors
    grid = Grid(x0=-0.3, y0=-0.6, cell=0.01, nx=270, ny=170)
    clean = _ridge_map(beams, grid, ghosts=False)
    assert fitted_surfaces(clean, grid, beams) is None
    noisy = _ridge_map(beams, grid, ghosts=True)
    first = choose_fit(noisy.processed, noisy.evidence, grid, beams)
    # the ghosts fool the map's decision, the refit through the echo points drops them ...
    assert first.choice == "surfaces" and first.surfaces is not None
    assert len(first.surfaces.surfaces) == 1
    # ... and the one open wall left is a function of x: the candidate stands aside
    assert fitted_surfaces(noisy, grid, beams) is None


def test_a_fold_of_a_long_log_finds_its_walls_as_the_run_on_every_reading_does() -> None:
    beams, _ = flat_wall_beams(120)
    grid = Grid(x0=-0.3, y0=-0.6, cell=0.01, nx=270, ny=170)
    noisy = _ridge_map(beams, grid, ghosts=True)
    # 120 readings are a short log: the walls come from the map's ridges ...
    by_size = choose_fit(noisy.processed, noisy.evidence, grid, beams)
    assert not by_size.criterion.startswith("a log of >=")
    # ... unless the caller says that they are a fold of a long log
    forced = choose_fit(noisy.processed, noisy.evidence, grid, beams, lines_first=True)
    assert forced.criterion.startswith("a log of >=")
    assert forced.surfaces is not None and len(forced.surfaces.surfaces) == 1
    assert fitted_surfaces(noisy, grid, beams, lines_first=True) is None
