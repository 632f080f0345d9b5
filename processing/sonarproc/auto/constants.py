"""Every constant ``--auto``'s decision depends on, with its value and its reason.

The values are the modules' own (imported, never copied), so the record
(report.json's ``auto.constants``, :func:`constants_record`) and the table of
``docs/methods.md`` say what the code does. (The sizes of the folds,
:data:`sonarproc.auto.select.REPEAT_READINGS`, :data:`~sonarproc.auto.select.MAX_REPEATS`
and :data:`~sonarproc.auto.select.REFIT_STARTS`, are added to the record by
:func:`sonarproc.auto.choose`, whose module imports this one.) Each constant's docstring
in its module gives the full reason; :data:`CONSTANTS` gives it in a line.
"""

from __future__ import annotations

from typing import NamedTuple

from sonarproc.auto.candidates import ORDERS, SMOOTHING_LENGTHS
from sonarproc.auto.echo_refit import MAX_PAIRS, MIN_ECHO_POINTS
from sonarproc.auto.holdout import MAX_SAMPLES
from sonarproc.auto.hull import HULL_READINGS, HULL_WINDOW_CELLS, SIDE_SHARE
from sonarproc.auto.refit_rounds import (
    END_GAP_M,
    END_SHARE,
    HULL_NOISE_WIDTH,
    NOISE_MAX,
    NOISE_READINGS,
    NOISE_WIDTHS,
    ROUNDS_M,
)
from sonarproc.auto.refit_ties import SPLINE_TIE_SE, TIE_SE
from sonarproc.auto.score import CAP_CELLS, COVERAGE_MIN, HULL_CELLS, SURFACES_MAX_CELLS, TRIM
from sonarproc.auto.scoring import FIT_COLUMNS
from sonarproc.auto.separation import SPLIT_GAP_M, STEP_M
from sonarproc.methods.echo_model import MIN_PATH_GAIN

__all__ = ["CONSTANTS", "NamedConstant", "constants_record"]

Value = float | int | tuple[float, ...]


class NamedConstant(NamedTuple):
    """One constant: where it lives, its value, its unit and why it has that value."""

    name: str
    module: str
    value: Value
    unit: str
    reason: str


def _c(name: str, module: str, value: Value, unit: str, reason: str) -> NamedConstant:
    where = module if "." in module else f"sonarproc.auto.{module}"
    return NamedConstant(name, where, value, unit, reason)


#: The constants, in the order the decision meets them.
CONSTANTS: tuple[NamedConstant, ...] = (
    _c("ORDERS", "candidates", tuple(float(o) for o in ORDERS), "polynomial order",
       "a parabola up to order 15, past which a least-squares fit over a few hundred "
       "columns is ill-conditioned"),
    _c("SMOOTHING_LENGTHS", "candidates", SMOOTHING_LENGTHS, "m",
       "doubling from 0.1 m (the detail a dense log resolves) to 1.6 m (a nearly straight "
       "wall)"),
    _c("CAP_CELLS", "score", CAP_CELLS, "cells (at least 5 cm)",
       "a reading further off echoed from something else: it costs every model the same"),
    _c("TRIM", "score", TRIM, "share of the held-out losses",
       "spurious echoes and other surfaces' echoes, a quarter of a log at most, do not decide"),
    _c("MAX_SAMPLES", "holdout", MAX_SAMPLES, "samples of a curve",
       "the echo model's step stays below a range resolution on a profile of a few metres"),
    _c("FIT_COLUMNS", "scoring", FIT_COLUMNS, "columns",
       "merged columns stay far shorter than the shortest wave a candidate may follow"),
    _c("HULL_CELLS", "score", HULL_CELLS, "cells",
       "a fit may leave its points' hull by the map's own cell-scale scatter, no more"),
    _c("HULL_WINDOW_CELLS", "hull", HULL_WINDOW_CELLS, "cells",
       "the hull's bins: several cells, so a slope crossing a bin is not an excess"),
    _c("HULL_READINGS", "hull", HULL_READINGS, "readings",
       "a few hundred echo points per metre of surface are plenty to place a hull"),
    _c("SIDE_SHARE", "hull", SIDE_SHARE, "share of the sensors",
       "the sensors' side of a profile: nearly all of them below (or above) it"),
    _c("COVERAGE_MIN", "score", COVERAGE_MIN, "share of the implied columns",
       "a profile must reach at least half of the columns the readings look at"),
    _c("SURFACES_MAX_CELLS", "score", SURFACES_MAX_CELLS, "cells",
       "the surfaces candidate's fit grows with the map: a 20 m room at 1 cm fits"),
    _c("SPLIT_GAP_M", "separation", SPLIT_GAP_M, "m",
       "a gap this wide between occupied columns may part two surfaces"),
    _c("STEP_M", "separation", STEP_M, "m",
       "runs whose facing ends differ by less continue one surface"),
    _c("ROUNDS_M", "refit_rounds", ROUNDS_M, "m",
       "a reading further than this from the predicted path echoed from something else"),
    _c("NOISE_WIDTHS", "refit_rounds", NOISE_WIDTHS, "range noise sigmas",
       "on a noisy log a round keeps readings within a few sigma, not only the lucky ones"),
    _c("NOISE_MAX", "refit_rounds", NOISE_MAX, "m",
       "a sonar's range noise is about 1 cm, 5 cm at worst: more says the profile is off"),
    _c("NOISE_READINGS", "refit_rounds", NOISE_READINGS, "readings",
       "the noise's median estimate is then good to a few per cent"),
    _c("HULL_NOISE_WIDTH", "refit_rounds", HULL_NOISE_WIDTH, "range noise sigmas",
       "echo points scatter by the noise: a smooth refit passes outside a few of them"),
    _c("END_GAP_M", "refit_rounds", END_GAP_M, "m",
       "a small cluster of echo points cut off at an end by this gap is a stray echo"),
    _c("END_SHARE", "refit_rounds", END_SHARE, "share of the echo points",
       "... when it holds less than this share of them"),
    _c("MIN_ECHO_POINTS", "echo_refit", MIN_ECHO_POINTS, "echo points",
       "fewer say the profile is not the surface the readings see"),
    _c("MAX_PAIRS", "echo_refit", MAX_PAIRS, "(reading, sample) pairs",
       "a long log's readings are subsampled so the refit costs a few runs"),
    _c("TIE_SE", "refit_ties", TIE_SE, "paired standard errors (readings)",
       "refits this close to the best, or to the chosen candidate, cannot be told apart"),
    _c("SPLINE_TIE_SE", "refit_ties", SPLINE_TIE_SE, "paired standard errors (firings)",
       "the one-standard-error rule between smoothing lengths, clustered by firing"),
    _c("MIN_PATH_GAIN", "sonarproc.methods.echo_model", MIN_PATH_GAIN,
       "m of path per m along the normal",
       "below it a range error moves the echo point more than twice as far"),
)  # fmt: skip


def constants_record() -> dict[str, Value]:
    """Each constant's value by name: report.json's ``auto.constants``.

    Examples
    --------
    >>> constants_record()["TRIM"]
    0.75
    """
    return {c.name: c.value for c in CONSTANTS}
