"""``--auto``: choose the map method, its thresholds and the fit family without ground truth.

The choice is made by a physical criterion: hold out firings, fit the profile on the
rest, predict each held-out reading's time of flight from the fitted curve with the
first-echo model, and keep the candidate whose robust held-out range residual is lowest
(:mod:`sonarproc.auto.holdout`). The candidates are a small stated set
(:data:`CANDIDATES`); guard rails exclude fits that leave their points' hull or that do
no better than a constant or a straight line (:mod:`sonarproc.auto.score`).

The names are loaded on first use (:func:`sonarproc.lazy.lazy_names`): the quality
stage's held-out folds (:mod:`sonarproc.auto.holdout`) then do not load the candidates'
whole selection in a run without ``--auto``.
"""

from typing import TYPE_CHECKING

from sonarproc.lazy import lazy_names

if TYPE_CHECKING:
    from sonarproc.auto.candidates import CANDIDATES, Candidate
    from sonarproc.auto.record import record_table
    from sonarproc.auto.score import CRITERION, HULL_CELLS, AutoChoice, Score
    from sonarproc.auto.select import choose, run_auto

__all__ = [
    "CANDIDATES",
    "CRITERION",
    "HULL_CELLS",
    "AutoChoice",
    "Candidate",
    "Score",
    "choose",
    "record_table",
    "run_auto",
]

#: Where each public name is defined.
_WHERE: dict[str, str] = {
    "CANDIDATES": "sonarproc.auto.candidates",
    "Candidate": "sonarproc.auto.candidates",
    "record_table": "sonarproc.auto.record",
    "CRITERION": "sonarproc.auto.score",
    "HULL_CELLS": "sonarproc.auto.score",
    "AutoChoice": "sonarproc.auto.score",
    "Score": "sonarproc.auto.score",
    "choose": "sonarproc.auto.select",
    "run_auto": "sonarproc.auto.select",
}

__getattr__ = lazy_names(__name__, _WHERE)
