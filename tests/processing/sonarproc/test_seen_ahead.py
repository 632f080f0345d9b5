"""The truth the sonars saw, found on a second thread while a run fits its surfaces."""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.methods.testing import flat_wall_beams
from sonarproc.pipeline.evaluation import SeenAhead
from sonarproc.pipeline.surfacefit import seen_of_truth
from sonarproc.surfaces import seen_truth, truth_points

# two surfaces: the wall the sensors face (y = 1) and one behind them, never in a beam
TRUTH = np.array([[-1.0, 1.0], [3.0, 1.0], [np.nan, np.nan], [-1.0, -1.0], [3.0, -1.0]])


def test_seen_ahead_is_seen_truth_of_the_readings() -> None:
    beams, _ = flat_wall_beams(10)
    p = beams.poses
    pts = np.concatenate(truth_points(TRUTH))
    want = seen_truth(pts, p.tx_xy, p.tx_heading, p.rx_xy, p.rx_heading, beams.path,
                      tx_half_beamwidth=p.tx_half_beamwidth,
                      rx_half_beamwidth=p.rx_half_beamwidth)  # fmt: skip
    ahead = SeenAhead(TRUTH, beams)
    got = ahead.result()
    assert np.array_equal(got, want)
    assert np.array_equal(seen_of_truth(TRUTH, beams), want)
    # the facing wall is seen in part, the one behind the sensors not at all
    on_front = pts[:, 1] > 0
    assert 0 < got[on_front].sum() < on_front.sum()
    assert not got[~on_front].any()
    assert ahead.cpu_s >= 0.0


def test_seen_ahead_raises_the_threads_error_on_the_callers() -> None:
    ahead = SeenAhead(TRUTH, None)  # type: ignore[arg-type]
    ahead.join()
    with pytest.raises(AttributeError):
        ahead.result()
