"""A fold's arc count map is the scored readings' minus its held-out readings'."""

from __future__ import annotations

import numpy as np

from sonarproc.arcs import rasterize
from sonarproc.auto.candidates import CANDIDATES
from sonarproc.auto.holdout import heldout_splits, subset_beams
from sonarproc.auto.scoring import CountMaps, _build
from sonarproc.methods.testing import flat_wall_beams
from sonarproc.params import RunParams


def test_a_fold_s_count_map_and_maps_are_those_its_training_readings_draw() -> None:
    beams, grid = flat_wall_beams(80)
    beams.readings["t"] = np.arange(beams.path.size)  # 80 firings, not one
    base = RunParams()
    counts = CountMaps(beams, grid, base)
    assert counts.whole is not None
    compared = 0
    for train, _ in heldout_splits(beams.readings, 4, 1, 10):
        tb = subset_beams(beams, train)
        fold = counts.training(train)
        assert fold is not None and fold.dtype == np.uint32
        assert np.array_equal(fold, rasterize(tb.arcs, grid))
        for c in CANDIDATES:
            if c.method not in ("arc-vote", "morphological"):
                continue
            drawn, shared = _build(c, tb, grid, base), _build(c, tb, grid, base, fold)
            if drawn is None:  # the method left nothing: so does it on the shared map
                assert shared is None, c.name
                continue
            assert shared is not None, c.name
            assert np.array_equal(drawn[0].processed, shared[0].processed), c.name
            assert np.array_equal(drawn[1].mean, shared[1].mean, equal_nan=True), c.name
            compared += 1
    assert compared >= 8
    # arcs drawn as samples are not shared: every map is drawn as the method draws it
    assert CountMaps(beams, grid, RunParams(arc_step=0.01)).training(train) is None
