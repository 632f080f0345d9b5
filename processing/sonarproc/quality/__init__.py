"""Truth-free quality of a run's map: how well it predicts its own readings.

A map of a room nobody measured is judged by the readings themselves, with the
first-echo prediction of ``--auto`` (:mod:`sonarproc.quality.predict`):
:func:`measure_quality` gives the held-out range residual (median and 90th percentile)
and the fraction of readings the map explains within 5 cm, per surface too
(:mod:`sonarproc.quality.measure`). Every ``sonarproc run`` reports them
(``RunResult.quality``, ``report.json``'s ``quality``).
"""

from sonarproc.quality.measure import (
    HELDOUT_FOLDS,
    MAX_EXPLAINED,
    MAX_HELDOUT,
    TOLERANCE,
    HeldOut,
    Quality,
    explained,
    held_out,
    measure_quality,
    training_map,
)
from sonarproc.quality.predict import MapCurves, map_curves, predict_paths

__all__ = [
    "HELDOUT_FOLDS",
    "MAX_EXPLAINED",
    "MAX_HELDOUT",
    "TOLERANCE",
    "HeldOut",
    "MapCurves",
    "Quality",
    "explained",
    "held_out",
    "map_curves",
    "measure_quality",
    "predict_paths",
    "training_map",
]
