"""Map-based refinement of an accepted drift correction: every echo's range to its wall.

The pose graph (:mod:`sonarproc.align.graph`) pulls echo points of one stretch of track
onto local lines of another. That removes most of the drift, but leaves errors of about
a centimetre that the echoes of one lap agree with (the whole map slightly scaled or
bent, the same on every lap): a local line carries the error of its own stretch, and
a stretch is never compared with itself. A map removes them: once the walls are known,
every echo's range must be its sensor's distance from the wall that returned it,
whichever stretch saw it, and a range is an absolute length (odometry's scale is
measured against it).

:func:`refine_alignment` therefore, starting from an accepted correction,

1. finds the walls from the readings' tangent votes under the corrected poses
   (:func:`sonarproc.align.walls.find_walls`), and the readings each wall returned;
2. solves (:mod:`sonarproc.align.bundle`), by :func:`scipy.optimize.least_squares`
   (finite differences over the sparse Jacobian's known structure), for the same smooth
   correction (node offsets, odometry calibration, with the same odometry ties and
   calibration prior), every wall's line and a common range delay together: a bundle
   adjustment whose residuals are each near-axis echo's first-echo range residual
   ``distance(sensor, wall) - range`` in range deviations (:data:`RANGE_SIGMA_M`;
   ``soft_l1`` on them, squares on the ties), the range less the time walk of its echo
   (:func:`sonarproc.align.bundle.wall_walk`);
3. finds the walls again under the refined poses and solves once more;
4. turns the refined track as a whole about its start to face as the accepted one did
   (the echoes cannot tell which way a whole map faces; see :func:`_placed_like`).

A reading's corrected pose moves its raw position rigidly by its two nodes' corrections
(:func:`blended_poses`), so the correction follows the track's turns between nodes.

The refinement is kept only when it lowers the robust cost on the walls found at the
accepted poses (their lines refitted for each set of poses) significantly: twice the
drop must exceed the chi-square 99th percentile (as for the correction itself,
:mod:`sonarproc.pipeline.alignment`) of the unknowns those walls' echoes determine
(:func:`sonarproc.align.bundle.echo_constrained_unknowns`). The accepted correction
already agrees with odometry wherever the echoes cannot tell, so noise in the ranges
lowers the cost only through the unknowns the echoes determine. Counting every unknown
of the correction (three times as many on the simulated transducer logs of the tests)
refused a refinement that took the pose error of a drifted three-lap log from 0.9 to
0.3 cm (twice the drop 156 against 226 for 179 unknowns; 93 for the 63 determined).

The cost is in nominal range deviations (:data:`RANGE_SIGMA_M`, wide enough for 1-inch
range steps); the echoes' part of the drop is judged in their own
(:func:`sonarproc.align.bundle.echo_dispersion`, their scatter about the walls at the
refined poses): noise half as wide lowers the cost a quarter as much. In nominal
deviations a refinement that took a two-lap log's pose error from 1.7 to 0.5 cm (and
its surfaces' precision from 2.8 to 1.1 times the drift-free run's) was at the chance
level, 59.7 against 61.5; its echoes scatter with 0.38 of the nominal variance, and
in their own deviations it is 158 against 70 (45 unknowns: more, as the echoes weigh
more against odometry).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from sonarlog import DEFAULT_SPEED_OF_SOUND
from sonarproc.align.bundle import (
    RANGE_SIGMA_M,
    WallProblem,
    bundle_cost,
    bundle_costs,
    echo_constrained_unknowns,
    echo_dispersion,
    lines_start,
    solve_bundle,
)
from sonarproc.align.echoes import echo_rays
from sonarproc.align.graph import NCAL, odometry_ties
from sonarproc.align.poses import Alignment
from sonarproc.align.track import Nodes, blended_poses, place_nodes, travel, wrap
from sonarproc.align.walls import find_walls

__all__ = ["RANGE_SIGMA_M", "Refinement", "blended_poses", "refine_alignment"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Bundle adjustments run (the walls found again before the second).
ROUNDS = 2
#: A refinement is kept when the chance that noise alone lowers the cost as much is
#: below this (the same level as the correction's own test).
SIGNIFICANCE = 0.01


@dataclass(frozen=True, eq=False)
class Refinement:
    """What the map-based refinement did.

    Attributes
    ----------
    alignment : Alignment
        The refined correction (the given one when not kept).
    kept : bool
        Whether the refinement was kept.
    walls : int
        Walls found at the accepted poses.
    echoes : int
        Readings those walls returned.
    cost_before, cost_after : float
        Robust cost of those readings (plus the odometry ties and calibration prior)
        at the accepted and at the refined correction, each with its walls refitted.
    dispersion : float
        The echoes' variance about those walls at the refined poses, as a fraction of the
        nominal one (:func:`sonarproc.align.bundle.echo_dispersion`).
    unknowns : float
        The unknowns those walls' echoes determine (the chi-square's degrees of freedom).
    cost_drop_x2, threshold : float
        Twice the drop (the echoes' part over ``dispersion``), and the chi-square
        percentile it had to pass.
    evaluations : int
        Residual evaluations of all solves.
    """

    alignment: Alignment
    kept: bool
    walls: int = 0
    echoes: int = 0
    cost_before: float = 0.0
    cost_after: float = 0.0
    dispersion: float = 1.0
    unknowns: float = 0.0
    cost_drop_x2: float = 0.0
    threshold: float = 0.0
    evaluations: int = 0

    def summary(self) -> dict[str, float | int | bool]:
        """The scalar figures, for a report."""
        return {
            "kept": self.kept,
            "walls": self.walls,
            "echoes": self.echoes,
            "cost_before": self.cost_before,
            "cost_after": self.cost_after,
            "dispersion": self.dispersion,
            "unknowns": self.unknowns,
            "cost_drop_x2": self.cost_drop_x2,
            "threshold": self.threshold,
            "evaluations": self.evaluations,
        }


def refine_alignment(
    readings: np.ndarray,
    sensors: np.ndarray,
    alignment: Alignment,
    *,
    speed_of_sound: float = DEFAULT_SPEED_OF_SOUND,
    node_spacing: float | None = None,
    turn_radius: float = 0.25,
    drift_fraction: float = 0.005,
    heading_drift: float = math.radians(0.5) / 10.0,
    position_floor: float = 0.005,
    heading_floor: float = math.radians(0.1),
    max_evaluations: int = 30,
) -> Refinement:
    """Refine a solved correction on every echo's range to its wall (see the module notes).

    Parameters
    ----------
    readings, sensors : ndarray
        The log's readings and sensors, as given to :func:`sonarproc.align.align_poses`.
    alignment : Alignment
        The correction :func:`~sonarproc.align.align_poses` solved (with no ``reason``).
    speed_of_sound : float
        m/s.
    node_spacing : float, optional
        The travel between the correction's nodes (m); by default the one
        :func:`~sonarproc.align.align_poses` solved for (``alignment.node_spacing_m``).
    turn_radius, drift_fraction, heading_drift : float
        As given to :func:`~sonarproc.align.align_poses` (the same nodes and the same
        odometry ties).
    position_floor, heading_floor : float
        The least standard deviation (m, rad) of an odometry tie, as the pose graph's.
    max_evaluations : int
        Most residual evaluations per solve.

    Returns
    -------
    Refinement
        The refined correction, or the given one (``kept`` False) when the walls are too
        few or the refinement is not significant.
    """
    from scipy.special import chdtri  # chi-square quantiles (scipy.stats is slow to load)

    if alignment.reason or readings.size == 0:
        return Refinement(alignment, False)
    order = np.argsort(readings["t"], kind="stable")
    r = readings[order]
    track = np.column_stack((r["x"], r["y"], r["theta"])).astype(np.float64)
    u = travel(track[:, 0], track[:, 1], track[:, 2], turn_radius=turn_radius)
    driven = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(track[:, :2], axis=0).T))))
    spacing = alignment.node_spacing_m if node_spacing is None else node_spacing
    nodes = place_nodes(u, spacing=spacing, driven=driven)
    if nodes.count != alignment.node_offsets.shape[0]:
        raise ValueError("refine_alignment: the alignment's nodes do not fit these options")
    rays = echo_rays(readings, sensors, order, speed_of_sound=speed_of_sound)
    turned = np.concatenate(([0.0], np.cumsum(np.abs(wrap(np.diff(track[:, 2]))))))
    ties = odometry_ties(
        track[nodes.at], np.diff(driven[nodes.at]), np.diff(turned[nodes.at]),
        drift_fraction=drift_fraction, heading_drift=heading_drift, turn_radius=turn_radius,
        position_floor=position_floor, heading_floor=heading_floor,
    )  # fmt: skip
    start = np.concatenate((alignment.node_offsets[1:].ravel(), alignment.calibration))
    walls = find_walls(
        rays, blended_poses(track, nodes, alignment.node_offsets, float(alignment.calibration[0]))
    )
    if walls.count < 2:
        # one wall fixes neither the position along it nor the scale
        return Refinement(alignment, False, walls.count, int(walls.ray.size))
    first = WallProblem(nodes, ties, rays, track, walls, speed_of_sound=speed_of_sound)
    x_before, evals = solve_bundle(first, np.concatenate((start, lines_start(walls))),
                             free_pose=False, max_evaluations=max_evaluations)  # fmt: skip
    x, pose = x_before, start
    prob = first
    for k in range(ROUNDS):
        if k > 0:
            off = np.vstack((np.zeros((1, 3)), pose[:-NCAL].reshape(-1, 3)))
            found = find_walls(rays, blended_poses(track, nodes, off, float(pose[-NCAL])))
            if found.count < 2:
                break
            prob = WallProblem(nodes, ties, rays, track, found, speed_of_sound=speed_of_sound)
            lines = lines_start(found)
            lines[-1] = x[-1]  # the range delay found so far
            x, n = solve_bundle(prob, np.concatenate((pose, lines)), free_pose=False,
                          max_evaluations=max_evaluations)  # fmt: skip
            evals += n
        x, n = solve_bundle(prob, x, free_pose=True, max_evaluations=max_evaluations)
        evals += n
        pose = x[: prob.n_pose]
    pose = _placed_like(pose, alignment.node_offsets, track[nodes.at])
    # judged on the walls found at the accepted poses, their lines refitted to each
    cost_before = bundle_cost(first, x_before)
    x_after, n = solve_bundle(first, np.concatenate((pose, x_before[first.n_pose :])),
                        free_pose=False, max_evaluations=max_evaluations)  # fmt: skip
    evals += n
    cost_after = bundle_cost(first, x_after)
    # the echoes' cost in their own deviations (their scatter about the walls at the
    # refined poses), and the chance level of the unknowns they determine at the accepted
    # poses (the null hypothesis: the accepted correction is right, the ranges are noise)
    dispersion = echo_dispersion(first, x_after)
    unknowns = echo_constrained_unknowns(first, x_before, dispersion)
    (ties_before, echoes_before), (ties_after, echoes_after) = (
        bundle_costs(first, x_before), bundle_costs(first, x_after))  # fmt: skip
    drop = 2.0 * ((ties_before - ties_after) + (echoes_before - echoes_after) / dispersion)
    threshold = float(chdtri(unknowns, SIGNIFICANCE)) if unknowns > 0 else math.inf
    kept = bool(drop > threshold)
    log.info("alignment refinement %s: %d walls, %d echoes, twice the cost drop %.3g vs %.3g "
             "(%.1f unknowns)", "kept" if kept else "not kept", walls.count, walls.ray.size,
             drop, threshold, unknowns)  # fmt: skip
    refined = alignment
    if kept:
        off = np.vstack((np.zeros((1, 3)), pose[:-NCAL].reshape(-1, 3)))
        refined = _with_offsets(alignment, track, order, nodes, off, pose[-NCAL:])
    return Refinement(refined, kept, walls.count, int(walls.ray.size), cost_before,
                      cost_after, dispersion, unknowns, drop, threshold, evals)  # fmt: skip


def _placed_like(pose: FloatArray, accepted: FloatArray, node_pose: FloatArray) -> FloatArray:
    """Refined pose parameters turned as a whole about the start (node 0, held) to face
    the way the accepted correction puts the track (the least-squares rotation of the
    corrected node positions about the start).

    The echoes fix the map's shape but not which way it faces: a map turned as a whole,
    walls and all, explains every range equally. Only the odometry of the first stretch
    (node 0 is held) resists it, so the bundle adjustment lets the whole map turn by a
    degree to fit a few millimetres of the ranges' systematic error (range steps seen at
    the same distance on every lap). The accepted correction turns the track by the
    matches of every stretch, and its heading as a whole is kept.
    """
    off = np.vstack((np.zeros((1, 3)), pose[:-NCAL].reshape(-1, 3)))
    start = node_pose[0, :2]
    p = node_pose[:, :2] + off[:, :2] - start
    q = node_pose[:, :2] + accepted[:, :2] - start
    h = p.T @ q
    angle = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    c, s = math.cos(angle), math.sin(angle)
    out = off.copy()
    out[:, :2] = p @ np.array([[c, s], [-s, c]]) + start - node_pose[:, :2]
    out[1:, 2] += angle
    return np.concatenate((out[1:].ravel(), pose[-NCAL:]))


def _with_offsets(a: Alignment, track: FloatArray, order: IntArray, nodes: Nodes,
                  offsets: FloatArray, calibration: FloatArray) -> Alignment:  # fmt: skip
    """``a`` with its node offsets and calibration replaced, and the poses they give."""
    corrected = blended_poses(track, nodes, offsets, float(calibration[0]))
    n = track.shape[0]
    x, y, th = np.empty(n), np.empty(n), np.empty(n)
    x[order], y[order], th[order] = corrected[:, 0], corrected[:, 1], corrected[:, 2]
    diff = np.hypot(*(corrected[:, :2] - track[:, :2]).T)
    return replace(
        a, x=x, y=y, theta=th, corrected_path=a.raw_path + offsets[:, :2],
        node_offsets=offsets, path_difference_max_m=float(diff.max()),
        path_difference_mean_m=float(diff.mean()),
        heading_difference_max_rad=float(np.abs(wrap(corrected[:, 2] - track[:, 2])).max()),
        calibration=calibration,
    )  # fmt: skip
