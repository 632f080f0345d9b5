"""Odometry drift correction in a run: align the poses where it helps, and say why.

:func:`align_log` runs the pose-graph solver (:func:`sonarproc.align.align_poses`) on a
log and keeps its correction only where the echoes say it is real: the solver must not
refuse, and the echoes must agree *significantly* better with the correction than
without it. A correction with ``p`` unknowns fitted to pure noise lowers the robust
cost (half the sum of squared residuals in standard deviations) by about ``p / 2``:
twice the reduction is chi-square with ``p`` degrees of freedom. The correction is
applied when twice the reduction exceeds that distribution's 99th percentile
(:data:`SIGNIFICANCE`).

The reduction is measured on the echo matches found at the raw poses, not on those the
solver's last round found near the corrected poses: matches chosen near a correction
favour it, and on logs of real transducers (corner and edge echoes, time walk) that
choice alone passed the test on drift-free logs and moved their poses by 10-40 cm. A
drift-free log then keeps its poses exactly (its results do not move), while a drift of
2 % of the distance still passes (by 1.6x on hall-pillar, the weakest case measured).

The robust cost grows linearly with a large residual, so a few wrong matches (a corner's
or an edge's echo matched to a wall's line, time walk at a beam's edge) can buy a
significant drop on their own. Real drift displaces *every* echo of a wall seen again, so
removing it brings the typical echo closer to its wall: the median absolute echo residual
on the same matches falls (to 0.62 and 0.34 of its raw value with 2 % drift on room-box and
hall-pillar). A correction is therefore also refused when that median grows
(:data:`MAX_MEDIAN_RATIO`): it then pulls in a few outliers at the cost of the echoes
that agreed; on a drift-free sparse log of crossing corridors such a correction passed
the chi-square test, grew the median by a third and moved the poses by 19 cm. Most such
outliers were corners' echoes matched to lines seen from far away; since echoes are
matched only where their line was seen (:func:`sonarproc.align.matching.line_matches`)
that log's correction no longer passes the chi-square test (26.2 against 87.2).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog

__all__ = ["MAX_MEDIAN_RATIO", "SIGNIFICANCE", "AlignmentRecord", "align_log"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: A correction is kept when the chance that noise alone lowers the echoes' cost as much
#: is below this.
SIGNIFICANCE = 0.01
#: A correction is kept only when the median absolute echo residual (on the matches found
#: at the raw poses) with it is at most this times the one without it: a correction of
#: drift makes the typical echo agree better, not worse (see the module notes).
MAX_MEDIAN_RATIO = 1.0


@dataclass(frozen=True, eq=False)
class AlignmentRecord:
    """What the drift correction did to a run's poses (``report.json``'s ``alignment``).

    Attributes
    ----------
    applied : bool
        Whether the run mapped the corrected poses.
    reason : str
        Why it was (the echoes' agreement improved significantly) or was not.
    raw_path, corrected_path : ndarray, shape (K, 2)
        The robot's position at the correction nodes, raw and corrected (the same when
        not applied); for the figure.
    max_shift_m, mean_shift_m, max_turn_rad : float
        Largest and mean position change of a reading, largest heading change, of the
        applied correction (0 when not applied).
    summary : dict
        The solver's figures (:meth:`sonarproc.align.Alignment.summary`), of the
        correction it found, applied or not.
    unknowns : int
        Unknowns of the correction (three per node after the first, two calibrations).
    cost_drop_x2, threshold : float
        Twice the echoes' cost reduction, and the chi-square percentile it had to pass.
    """

    applied: bool
    reason: str
    raw_path: FloatArray
    corrected_path: FloatArray
    max_shift_m: float
    mean_shift_m: float
    max_turn_rad: float
    summary: dict[str, Any]
    unknowns: int = 0
    cost_drop_x2: float = 0.0
    threshold: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """JSON-ready record (the contract in docs/formats.md)."""
        return {
            "applied": self.applied,
            "reason": self.reason,
            "max_shift_m": self.max_shift_m,
            "mean_shift_m": self.mean_shift_m,
            "max_turn_rad": self.max_turn_rad,
            "unknowns": self.unknowns,
            "cost_drop_x2": self.cost_drop_x2,
            "threshold": self.threshold,
            "summary": dict(self.summary),
        }


def align_log(log_: SonarLog) -> tuple[SonarLog, AlignmentRecord]:
    """The log with its poses aligned where that helps, and the record of why.

    Returns
    -------
    log : sonarlog.SonarLog
        ``log_`` itself when the correction is not applied, else a copy whose readings
        carry the corrected poses (:func:`sonarproc.align.corrected_readings`).
    record : AlignmentRecord
    """
    from scipy.special import chdtri  # chi-square quantiles (scipy.stats is slow to load)

    from sonarproc.align import align_poses, corrected_readings

    a = align_poses(log_.readings, log_.sensors, speed_of_sound=log_.speed_of_sound)
    summary = a.summary()
    unknowns = 3 * (int(a.node_offsets.shape[0]) - 1) + int(a.calibration.size)
    drop = 2.0 * (a.cost_before - a.cost_after)
    threshold = float(chdtri(unknowns, SIGNIFICANCE)) if unknowns > 0 else 0.0
    if a.reason:
        applied, why = False, a.reason
    elif not drop > threshold:
        applied = False
        why = (
            f"the correction does not make the echoes agree significantly better (twice "
            f"the cost drop {drop:.3g} <= {threshold:.3g}, the chance level of "
            f"{unknowns} unknowns)"
        )
    elif a.echo_median_after_m > MAX_MEDIAN_RATIO * a.echo_median_before_m:
        applied = False
        why = (
            f"the correction makes the typical echo agree worse (median echo residual "
            f"{100 * a.echo_median_before_m:.2g} -> {100 * a.echo_median_after_m:.2g} cm): "
            f"its cost drop comes from a few outlying echoes, not from drift"
        )
    else:
        applied = True
        why = f"the echoes agree better (twice the cost drop {drop:.3g} > {threshold:.3g})"
    log.info("alignment %s: %s", "applied" if applied else "not applied", why)
    if not applied:
        path = np.asarray(a.raw_path, dtype=np.float64)
        record = AlignmentRecord(False, why, path, path.copy(), 0.0, 0.0, 0.0, summary,
                                 unknowns, drop, threshold)  # fmt: skip
        return log_, record
    # only an applied correction is refined: a declined log costs nothing more
    from sonarproc.align.refine import refine_alignment

    refined = refine_alignment(log_.readings, log_.sensors, a, speed_of_sound=log_.speed_of_sound)
    a = refined.alignment
    summary = {**a.summary(), **{f"refinement_{k}": v for k, v in refined.summary().items()}}
    record = AlignmentRecord(
        True, why, np.asarray(a.raw_path), np.asarray(a.corrected_path),
        a.path_difference_max_m, a.path_difference_mean_m, a.heading_difference_max_rad,
        summary, unknowns, drop, threshold,
    )  # fmt: skip
    return replace(log_, readings=corrected_readings(log_.readings, a)), record
