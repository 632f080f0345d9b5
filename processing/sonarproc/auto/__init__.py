"""``--auto``: choose the map method, its thresholds and the fit family without ground truth.

The choice is made by a physical criterion: hold out firings, fit the profile on the
rest, predict each held-out reading's time of flight from the fitted curve with the
first-echo model, and keep the candidate whose robust held-out range residual is lowest
(:mod:`sonarproc.auto.holdout`). The candidates are a small stated set
(:data:`CANDIDATES`); guard rails exclude fits that leave their points' hull or that do
no better than a constant or a straight line (:mod:`sonarproc.auto.score`).
"""

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
