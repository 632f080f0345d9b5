"""An arc candidate's RMS residual is the distance of its cells to its polyline."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.arcs import arc_candidate
from sonarproc.surfaces.planar.polylines import distance_to_polylines


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.floats(0.05, 5.0),
    st.floats(0.05, 2 * math.pi),
    st.booleans(),
    st.booleans(),
)
def test_arc_rms_is_the_distance_to_its_polyline(
    seed: int, radius: float, sweep: float, backwards: bool, closed: bool
) -> None:
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-3.0, 3.0, 2)
    phi = rng.uniform(-4.0, 4.0) + np.sort(rng.uniform(0.0, sweep, 80))
    if backwards:
        phi = phi[::-1]
    # cells near the arc, a few far off (inside, outside, beyond its ends)
    r = radius + rng.normal(0.0, 0.02, phi.size)
    r[::10] = rng.uniform(0.0, 3 * radius, r[::10].size)
    x, y = centre[0] + r * np.cos(phi), centre[1] + r * np.sin(phi)
    cells = SurfaceCells(x, y, np.arange(x.size) * 0.01, np.ones_like(x), closed)
    arc = arc_candidate(cells, centre, radius, 0.01)
    d = distance_to_polylines(np.stack((x, y), axis=1), [arc.polyline])
    # the fit measures its residuals by another float path than distance_to_polylines does
    assert arc.rms == pytest.approx(float(np.sqrt(np.mean(d**2))), rel=1e-4, abs=1e-9)
