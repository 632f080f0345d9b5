"""Align a log's poses: the public entry points (see the package notes)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarlog import DEFAULT_SPEED_OF_SOUND
from sonarproc.align.echoes import echo_rays
from sonarproc.align.graph import CALIBRATION_PRIOR, NCAL, correction_costs, odometry_ties
from sonarproc.align.matching import RayFrame
from sonarproc.align.rounds import RoundsContext, association_rounds
from sonarproc.align.track import apply_offsets, interpolate_offsets, place_nodes, travel, wrap

__all__ = ["Alignment", "align_poses", "align_readings", "corrected_readings"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: A calibration beyond this many prior deviations (15 %, 15 degrees per 10 m) is not
#: odometry drift; the correction is then refused.
PLAUSIBLE = 3.0
#: Fewest echo matches per correction node (three per unknown) for a correction.
MATCHES_PER_NODE = 9
#: Coarsest node spacing (m) tried when the echoes are too few for the default one. A
#: correction interpolated linearly between nodes misses the bend a heading drift puts
#: in the track between them, ``h s**2 / 8`` over a spacing ``s``: at the calibration
#: prior's heading drift (5 degrees per 10 m) that is 1 cm, the sonar's range noise, at
#: 3 m.
MAX_NODE_SPACING = 3.0


@dataclass(frozen=True, eq=False)
class Alignment:
    """A smooth correction of a log's pose track (SI units, arrays per reading row).

    Attributes
    ----------
    x, y, theta : ndarray, shape (N,)
        Corrected base pose of every reading, in the readings' row order.
    raw_path, corrected_path : ndarray, shape (K, 2)
        The robot's position at each correction node, before and after.
    node_offsets : ndarray, shape (K, 3)
        The correction ``(dx, dy, dtheta)`` at each node (the first is zero).
    path_difference_max_m, path_difference_mean_m : float
        Largest and mean distance between a reading's raw and corrected position.
    heading_difference_max_rad : float
        Largest heading correction.
    rounds, evaluations : int
        Association rounds run, and residual evaluations in all of them.
    matches : int
        Echo points matched to another stretch's lines in the last round.
    cost_before, cost_after : float
        The robust cost of the first round's matches (those found at the raw poses)
        with no correction and with the final correction.
    calibration : ndarray, shape (2,)
        The odometry's systematic errors found: distance scale error (fraction) and
        heading error per metre driven (rad/m), as corrections (the raw odometry's own
        errors have the opposite sign).
    reason : str
        Why the poses were left as they were, or ``""`` when a correction was solved.
    echo_median_before_m, echo_median_after_m : float
        Median absolute echo residual (m) on the same matches as ``cost_before`` and
        ``cost_after``: how well the typical echo agrees with its wall.
    node_spacing_m : float
        Travel between the correction nodes solved for (m): the one asked for, or a
        coarser one when the echoes were too few for it (see :func:`align_poses`).
    """

    x: FloatArray
    y: FloatArray
    theta: FloatArray
    raw_path: FloatArray
    corrected_path: FloatArray
    node_offsets: FloatArray
    path_difference_max_m: float
    path_difference_mean_m: float
    heading_difference_max_rad: float
    rounds: int
    evaluations: int
    matches: int
    cost_before: float
    cost_after: float
    calibration: FloatArray
    reason: str = ""
    echo_median_before_m: float = 0.0
    echo_median_after_m: float = 0.0
    node_spacing_m: float = 1.0

    def summary(self) -> dict[str, float | int | str]:
        """The scalar figures, for a report."""
        return {
            "nodes": int(self.node_offsets.shape[0]),
            "node_spacing_m": self.node_spacing_m,
            "path_difference_max_m": self.path_difference_max_m,
            "path_difference_mean_m": self.path_difference_mean_m,
            "heading_difference_max_rad": self.heading_difference_max_rad,
            "rounds": self.rounds,
            "evaluations": self.evaluations,
            "matches": self.matches,
            "cost_before": self.cost_before,
            "cost_after": self.cost_after,
            "echo_median_before_m": self.echo_median_before_m,
            "echo_median_after_m": self.echo_median_after_m,
            "odometry_scale_error": float(self.calibration[0]),
            "odometry_heading_rate_rad_per_m": float(self.calibration[1]),
            "reason": self.reason,
        }


def _unchanged(readings: np.ndarray, reason: str, spacing: float = 1.0) -> Alignment:
    x = np.asarray(readings["x"], dtype=np.float64)
    y = np.asarray(readings["y"], dtype=np.float64)
    th = np.asarray(readings["theta"], dtype=np.float64)
    path = np.column_stack((x[:1], y[:1]))
    log.info("alignment: poses left unchanged: %s", reason)
    return Alignment(x.copy(), y.copy(), th.copy(), path, path.copy(), np.zeros((1, 3)),
                     0.0, 0.0, 0.0, 0, 0, 0, 0.0, 0.0, np.zeros(NCAL), reason,
                     node_spacing_m=spacing)  # fmt: skip


def align_poses(
    readings: np.ndarray,
    sensors: np.ndarray,
    *,
    speed_of_sound: float = DEFAULT_SPEED_OF_SOUND,
    node_spacing: float = 1.0,
    turn_radius: float = 0.25,
    drift_fraction: float = 0.005,
    heading_drift: float = math.radians(0.5) / 10.0,
    echo_sigma: float = 0.03,
    match_radius: tuple[float, float] = (0.5, 0.2),
    min_points: int = 4,
    min_places: int = 3,
    queries_per_node: int = 60,
    rounds: int = 5,
    max_evaluations: int = 50,
) -> Alignment:
    """Estimate a smooth correction of the pose track so that echoes of a wall agree.

    A pose graph over the track (:mod:`sonarproc.align`): nodes about every
    ``node_spacing`` of travel hold offsets, interpolated between them for every reading;
    consecutive nodes are tied by odometry; echo points of one stretch are matched to
    lines of echo points of other stretches and pulled onto them. Matches are found
    again after each solve (``rounds`` times at most, the match radius shrinking
    geometrically from the first value of ``match_radius`` to the second), until the
    correction moves no reading by more than 1 mm.

    Parameters
    ----------
    readings : ndarray of sonarlog.READING_DTYPE
        The log's readings (any row order; time order is taken from ``t``).
    sensors : ndarray of sonarlog.SENSOR_DTYPE
        The log's sensors.
    speed_of_sound : float
        m/s, to turn times of flight into ranges.
    node_spacing : float
        Travel between correction nodes (m). At 2 % drift the pose errs by 2 cm over
        1 m, less than an echo's noise: a correction interpolated linearly over 1 m
        follows the drift closely enough. Where fewer than 9 echoes per node match
        another stretch, twice and three times this spacing are tried in turn (up to
        :data:`MAX_NODE_SPACING`): echoes that see a wall again from far along the
        track (a loop, a corridor driven back) match as often whatever the spacing,
        and then observe the same drift with fewer unknowns.
    turn_radius : float
        Travel counted per radian turned (m): the arc a wheel runs while a differential
        drive of about 0.5 m wheel base turns on the spot, where odometry errs too.
    drift_fraction, heading_drift : float
        Standard deviation of odometry's *random* error per metre driven, once its
        systematic errors (scale, heading per metre, turn scale; estimated here) are
        taken out: of position as a fraction of the distance (0.5 %), of heading in
        rad/m (0.5 degrees per 10 m). On an indoor floor a wheeled robot's random
        errors are a fraction of its systematic ones (which reach a few per cent and a
        few degrees per 10 m uncalibrated).
    echo_sigma : float
        Standard deviation of a line-of-sight echo point about its wall (m): sonar range
        noise and quantisation (about 1 cm) plus the line-of-sight point's offset in
        front of an obliquely seen wall (a few per cent of the range).
    match_radius : (float, float)
        First and last match radius (m): the first must exceed the pose error where a
        wall is seen again; the last, a few echo deviations, keeps wrong matches out.
    min_points : int
        Fewest echo points of another stretch a local line needs.
    min_places : int
        Fewest distinct places (1 cm of travel apart) those points must be seen from:
        the echoes of one place pair into chance lines (two walls, a corner).
    queries_per_node : int
        Most echo points matched per round, per ``node_spacing`` of travel, spread
        evenly along the track: a few times the 9 per node a correction needs (a long
        log's walls are seen many times over; the cost then grows with the track, not
        with the readings).
    rounds : int
        Most association rounds.
    max_evaluations : int
        Most residual evaluations per round's solve.

    Returns
    -------
    Alignment
        Corrected poses per reading; unchanged, with ``reason``, when the track is
        shorter than a node spacing, fewer than 9 echoes per node (three per unknown)
        match another stretch even at the coarsest spacing tried, or the correction
        needs an odometry calibration no robot has (a distance scale off by more than
        15 % or a heading drift beyond 15 degrees per 10 m: the echoes were then matched
        to the wrong walls).

    Examples
    --------
    A log without readings that echo is left as it is:

    >>> from sonarlog import READING_DTYPE, SENSOR_DTYPE
    >>> a = align_poses(np.zeros(3, READING_DTYPE), np.zeros(1, SENSOR_DTYPE))
    >>> a.reason, a.path_difference_max_m
    ('the track is shorter than half a node spacing', 0.0)
    """
    if readings.size == 0:
        return _unchanged(readings, "no readings")
    order = np.argsort(readings["t"], kind="stable")
    r = readings[order]
    track = np.column_stack((r["x"], r["y"], r["theta"])).astype(np.float64)
    if not np.all(np.isfinite(track)):
        return _unchanged(readings, "the poses are not all finite (x, y, theta)")
    if sensors.size == 0:
        return _unchanged(readings, "the log has no sensor table")
    mounts = [sensors[n] for n in sensors.dtype.names or () if sensors.dtype[n].kind == "f"]
    if not all(np.all(np.isfinite(m)) for m in mounts):
        return _unchanged(readings, "a sensor's mount is not finite")
    with np.errstate(over="ignore"):  # an absurd track overflows: refused just below
        u = travel(track[:, 0], track[:, 1], track[:, 2], turn_radius=turn_radius)
    if not np.isfinite(u[-1]) or u[-1] > node_spacing * readings.size:
        # each node needs echoes of its own to be placed: more nodes than readings
        # leaves the graph undetermined (and a track that long is a corrupt log)
        return _unchanged(readings, "the track has more node spacings than readings")
    driven = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(track[:, :2], axis=0).T))))
    nodes = place_nodes(u, spacing=node_spacing, driven=driven)
    if nodes.count < 2:
        return _unchanged(readings, "the track is shorter than half a node spacing")
    rays = echo_rays(readings, sensors, order, speed_of_sound=speed_of_sound)
    turned = np.concatenate(([0.0], np.cumsum(np.abs(wrap(np.diff(track[:, 2]))))))
    ray_pose = track[rays.reading]
    raw_xy, raw_look = rays.sensors(ray_pose[:, 0], ray_pose[:, 1], ray_pose[:, 2])
    raw_points = rays.points(ray_pose[:, 0], ray_pose[:, 1], ray_pose[:, 2])
    raw = RayFrame(raw_points, raw_xy, raw_look, rays.range_m, rays.half_beam,
                   u[rays.reading], ray_pose[:, :2])  # fmt: skip
    # the sample of queries is set by the track's length (per node_spacing of travel),
    # not by the nodes solved for: coarser nodes then get more queries each
    wanted = min(queries_per_node * nodes.count, rays.size)
    queries = np.unique(np.linspace(0, rays.size - 1, wanted).astype(np.intp))
    used = node_spacing
    for spacing in _spacings(node_spacing):
        coarser = place_nodes(u, spacing=spacing, driven=driven)
        if coarser.count < 2:
            break
        nodes, used = coarser, spacing
        ties = odometry_ties(
            track[nodes.at], np.diff(driven[nodes.at]), np.diff(turned[nodes.at]),
            drift_fraction=drift_fraction, heading_drift=heading_drift,
            turn_radius=turn_radius, position_floor=0.005, heading_floor=math.radians(0.1),
        )  # fmt: skip
        context = RoundsContext(nodes, ties, rays, track, ray_pose, raw, nodes.lo[rays.reading])
        solved = association_rounds(context, queries, MATCHES_PER_NODE * nodes.count,
                         far_only=spacing > node_spacing, rounds=rounds,
                         match_radius=match_radius, min_points=min_points,
                         min_places=min_places, echo_sigma=echo_sigma,
                         max_evaluations=max_evaluations)  # fmt: skip
        if not solved.short or (solved.matched == 0 and spacing == node_spacing):
            break
        # Too few matches for this many nodes. Where echoes see a wall again from far
        # along the track (a loop, a corridor driven back), those matches do not depend
        # on the spacing, and coarser nodes observe the same drift with fewer unknowns.
        # A coarser spacing counts only those (far_only): on a single pass, whose
        # matches join neighbouring stretches of one wall, the log stays refused.
    offsets, calibration, matched = solved.offsets, solved.calibration, solved.matched
    done, evaluations, first_matches = solved.rounds, solved.evaluations, solved.first_matches
    cost_before = cost_after = med_before = med_after = 0.0
    if matched == 0 and used == node_spacing:
        return _unchanged(readings, "no echo point matches another stretch of the track")
    if solved.short:
        which = "other stretches" if used == node_spacing else "stretches not next to their own"
        return _unchanged(
            readings,
            f"too few echoes match {which} of the track ({matched} for "
            f"{nodes.count} nodes {used:.3g} m apart; {MATCHES_PER_NODE} per node needed)",
            used,
        )
    if np.any(np.abs(calibration) > PLAUSIBLE * CALIBRATION_PRIOR):
        # no working odometry errs this much: the echoes were matched to the wrong walls
        return _unchanged(
            readings,
            f"the correction found is implausible for odometry (scale {calibration[0]:+.3f}, "
            f"heading {math.degrees(calibration[1]) * 10.0:+.1f} degrees per 10 m)",
        )
    if first_matches is not None:
        # Judged on the matches found at the raw poses, not on the last round's: those
        # were chosen near the corrected poses, so the raw poses' cost on them is inflated
        # by the choice itself (an echo's structure, such as a corner's, read as drift).
        judged = correction_costs(
            nodes, ties, rays, track, first_matches, offsets, calibration, echo_sigma=echo_sigma
        )
        cost_before, cost_after = judged.cost_before, judged.cost_after
        med_before, med_after = judged.median_before_m, judged.median_after_m
    per = interpolate_offsets(offsets, nodes.lo, nodes.w, nodes.w_xy)
    cx, cy, cth = apply_offsets(track[:, 0], track[:, 1], track[:, 2], per)
    x, y, th = np.empty(r.size), np.empty(r.size), np.empty(r.size)
    x[order], y[order], th[order] = cx, cy, cth
    diff = np.hypot(per[:, 0], per[:, 1])
    raw_path = track[nodes.at, :2]
    return Alignment(
        x, y, th, raw_path, raw_path + offsets[:, :2], offsets,
        float(diff.max()), float(diff.mean()), float(np.abs(per[:, 2]).max()),
        done, evaluations, matched, cost_before, cost_after, calibration, "",
        med_before, med_after, used,
    )  # fmt: skip


def _spacings(node_spacing: float) -> list[float]:
    """The node spacings tried, finest first: ``node_spacing`` and its multiples up to
    :data:`MAX_NODE_SPACING` (``node_spacing`` alone when it is already coarser).

    >>> _spacings(1.0), _spacings(5.0)
    ([1.0, 2.0, 3.0], [5.0])
    """
    top = max(MAX_NODE_SPACING, node_spacing)
    return [node_spacing * k for k in range(1, 4) if node_spacing * k <= top + 1e-9]


def corrected_readings(readings: np.ndarray, alignment: Alignment) -> np.ndarray:
    """A copy of ``readings`` (same dtype) with the aligned poses.

    ``x``, ``y`` and ``theta`` take the corrected values; ``turret`` turns with
    ``theta`` (the turret's heading relative to the base is what the robot measured).

    Examples
    --------
    >>> from sonarlog import READING_DTYPE, SENSOR_DTYPE
    >>> r = np.zeros(2, READING_DTYPE)
    >>> a = align_poses(r, np.zeros(1, SENSOR_DTYPE))
    >>> out = corrected_readings(r, a)
    >>> out.dtype == r.dtype, out is r
    (True, False)
    """
    if alignment.x.shape != readings.shape:
        raise ValueError(f"alignment: has {alignment.x.size} poses for {readings.size} readings")
    out = readings.copy()
    turn = wrap(alignment.theta - np.asarray(readings["theta"], dtype=np.float64))
    out["x"], out["y"], out["theta"] = alignment.x, alignment.y, alignment.theta
    out["turret"] = wrap(np.asarray(readings["turret"], dtype=np.float64) + turn)
    return out


def align_readings(
    readings: np.ndarray, sensors: np.ndarray, **options: object
) -> tuple[np.ndarray, Alignment]:
    """:func:`align_poses` then :func:`corrected_readings`: the corrected copy and how."""
    alignment = align_poses(readings, sensors, **options)  # type: ignore[arg-type]
    return corrected_readings(readings, alignment), alignment
