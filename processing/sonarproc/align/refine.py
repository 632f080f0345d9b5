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
   (:func:`sonarproc.surfaces.echoes.tangents.tangent_lines`), and the readings each
   wall returned;
2. solves, by :func:`scipy.optimize.least_squares` (finite differences over the sparse
   Jacobian's known structure), for the same smooth correction (node offsets, odometry
   calibration, with the same odometry ties and calibration prior), every wall's line
   and a common range delay together: a bundle adjustment whose residuals are each
   near-axis echo's first-echo range residual ``distance(sensor, wall) - range`` in
   range deviations (:data:`RANGE_SIGMA_M`; ``soft_l1`` on them, squares on the ties);
3. finds the walls again under the refined poses and solves once more;
4. turns the refined track as a whole about its start to face as the accepted one did
   (the echoes cannot tell which way a whole map faces; see :func:`_placed_like`).

A reading's corrected pose moves its raw position rigidly by its two nodes' corrections
(:func:`blended_poses`), so the correction follows the track's turns between nodes.

The refinement is kept only when it lowers the robust cost on the walls found at the
accepted poses (their lines refitted for each set of poses) significantly: twice the
drop must exceed the chi-square 99th percentile of the correction's unknowns, as for
the correction itself (:mod:`sonarproc.pipeline.alignment`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix

from sonarlog import DEFAULT_SPEED_OF_SOUND
from sonarproc.align.echoes import EchoRays, echo_rays
from sonarproc.align.graph import NCAL, ROBUST_SCALE, OdometryTies, odometry_ties
from sonarproc.align.graph import PoseGraphProblem as _OdometryProblem
from sonarproc.align.matching import LineMatches
from sonarproc.align.poses import Alignment
from sonarproc.align.track import Nodes, place_nodes, travel
from sonarproc.align.track import wrap as _wrap
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.echoes.tangents import tangent_lines

__all__ = ["RANGE_SIGMA_M", "Refinement", "refine_alignment"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Standard deviation (m) of a first echo's range about its sensor's distance from a flat
#: wall: 1-inch range steps (2.54 cm / sqrt(12) = 0.73 cm) and a few millimetres of
#: timing noise, about 1 cm. A wrong association costs linearly beyond
#: ``ROBUST_SCALE`` of these (the loss is ``soft_l1``).
RANGE_SIGMA_M = 0.01
#: A reading belongs to a wall when its range tangent lies within this (m) of the wall's
#: line: five range deviations, and under the pose errors the graph leaves (about 1 cm).
WALL_TOL_M = 0.05
#: Fewest readings per wall: a wall seen from fewer places hardly constrains the poses,
#: and fewer readings can pair by chance into a line.
WALL_MIN_VOTES = 20
#: Echo points further apart along a line (m) start another wall: a doorway or a gap
#: (the surfaces' own bridge, see :mod:`sonarproc.pipeline.surfacefit`).
WALL_BRIDGE_M = 0.30
#: Shortest wall (m): a few beam footprints, so that a corner's or an edge's echoes
#: (a point that looks like a short line) are not taken for a wall.
WALL_MIN_SPREAD_M = 0.5
#: An echo is used when its wall's normal lies within this fraction of the half beam
#: width of the sensor's axis. Off the axis the echo is weaker (the beam pattern), so it
#: crosses the receiver's threshold later (time walk) and its range is long, by more
#: the weaker it is: centimetres at a few metres near the beam's edge. Those errors are
#: the same each time a wall is seen from the same place, and a map-based refinement
#: would bend the track to fit them.
AXIS_FRACTION = 0.5
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
    cost_drop_x2, threshold : float
        Twice the drop, and the chi-square percentile it had to pass.
    evaluations : int
        Residual evaluations of all solves.
    """

    alignment: Alignment
    kept: bool
    walls: int = 0
    echoes: int = 0
    cost_before: float = 0.0
    cost_after: float = 0.0
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
            "cost_drop_x2": self.cost_drop_x2,
            "threshold": self.threshold,
            "evaluations": self.evaluations,
        }


@dataclass(frozen=True, eq=False)
class _Walls:
    """Walls found under some poses: the rays each returned and a start for its line."""

    ray: IntArray  # rays that a wall returned (M,), indices into all rays
    wall: IntArray  # the wall of each (M,), 0 .. L - 1
    centre: FloatArray  # a point of each wall (L, 2): lines are placed relative to it
    phi: FloatArray  # direction of each wall's normal (L,), away from its sensors

    @property
    def count(self) -> int:
        return int(self.phi.size)


def _empty_matches() -> LineMatches:
    z2 = np.zeros((0, 2))
    return LineMatches(np.zeros(0, dtype=np.intp), z2, z2.copy(), np.zeros(0), z2.copy())


class _WallProblem:
    """Residuals of the bundle adjustment (odometry, calibration, echoes) and which
    unknowns each depends on (for sparse finite differences)."""

    def __init__(self, nodes: Nodes, ties: OdometryTies, rays: EchoRays, track: FloatArray,
                 walls: _Walls) -> None:  # fmt: skip
        self.odometry = _OdometryProblem(nodes, ties, rays, track, _empty_matches(), 1.0)
        self.n_pose = 3 * (nodes.count - 1) + NCAL
        self.first_echo = 3 * (nodes.count - 1) + NCAL
        self.walls = walls
        self.rays = rays.subset(walls.ray)
        reading = self.rays.reading
        self.q_pose = track[reading]
        self.q_lo, self.q_w, self.q_wxy = nodes.lo[reading], nodes.w[reading], nodes.w_xy[reading]
        self.node_xy = ties.pose[:, :2]

    def split(self, params: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, float]:
        """Pose parameters, wall normal directions (L,), wall offsets (L,), range delay."""
        line = params[self.n_pose : -1].reshape(-1, 2)
        return params[: self.n_pose], line[:, 0], line[:, 1], float(params[-1])

    def _sensor(self, pose_params: FloatArray) -> FloatArray:
        """Sensor positions (M, 2): each reading's raw position moved rigidly (and scaled
        by the calibration) by its two nodes' corrections, blended by its weights.

        Moving the raw position rigidly, rather than adding an interpolated offset,
        follows the raw track's own bends: where the robot turns between two nodes the
        drift's offset turns with it (an offset interpolated along the track cuts the
        corner by millimetres, as much as the echoes can tell apart)."""
        off = np.vstack((np.zeros((1, 3)), pose_params[:-NCAL].reshape(-1, 3)))
        grow = 1.0 + pose_params[-NCAL]
        p = self.q_pose[:, :2]
        pos = np.zeros_like(p)
        for node, weight in ((self.q_lo, 1.0 - self.q_wxy), (self.q_lo + 1, self.q_wxy)):
            c, s = np.cos(off[node, 2]), np.sin(off[node, 2])
            rel = p - self.node_xy[node]
            moved = np.column_stack((c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]))
            pos += weight[:, None] * (self.node_xy[node] + off[node, :2] + grow * moved)
        turn = (1.0 - self.q_w) * off[self.q_lo, 2] + self.q_w * off[self.q_lo + 1, 2]
        turret = self.q_pose[:, 2] + turn + self.rays.turret_offset
        c, s = np.cos(turret), np.sin(turret)
        m = self.rays.mount
        return pos + np.column_stack((c * m[:, 0] - s * m[:, 1], s * m[:, 0] + c * m[:, 1]))

    def residuals(self, params: FloatArray) -> FloatArray:
        pose, phi, d, delay = self.split(params)
        sensor = self._sensor(pose)
        w = self.walls.wall
        normal = np.column_stack((np.cos(phi), np.sin(phi)))[w]
        reach = d[w] + np.sum(normal * (self.walls.centre[w] - sensor), axis=1)
        r_echo = (reach - self.rays.range_m + delay) / RANGE_SIGMA_M
        return np.concatenate((self.odometry.residuals(pose), r_echo))

    def sparsity(self) -> csr_matrix:
        """Which unknowns each residual depends on (for finite differences)."""
        n_walls, m = self.walls.count, self.walls.ray.size
        x = np.zeros(self.n_pose + 2 * n_walls + 1)
        odo = self.odometry.jacobian(x[: self.n_pose]).tocoo()
        rows = [odo.row]
        cols = [odo.col]
        row = np.arange(m) + odo.shape[0]
        for node in (self.q_lo, self.q_lo + 1):
            ok = node > 0
            for comp in range(3):
                rows.append(row[ok])
                cols.append(3 * (node[ok] - 1) + comp)
        w = self.walls.wall
        rows += [row, row, row, row]
        cols += [self.n_pose + 2 * w, self.n_pose + 2 * w + 1,
                 np.full(m, self.n_pose - NCAL, dtype=np.intp),
                 np.full(m, x.size - 1, dtype=np.intp)]  # fmt: skip
        r, c = np.concatenate(rows), np.concatenate(cols)
        shape = (odo.shape[0] + m, x.size)
        return csr_matrix((np.ones(r.size), (r, c)), shape=shape)


def blended_poses(track: FloatArray, nodes: Nodes, offsets: FloatArray,
                  scale: float) -> FloatArray:  # fmt: skip
    """Corrected poses (N, 3) of a time-ordered raw ``track``: each raw position moved
    rigidly by its two nodes' corrections (turned about the node's raw position by its
    heading offset, scaled by ``1 + scale``, shifted by its position offset), blended by
    its distance weight; the heading offset blended by travel.

    On a straight stretch this is the offset interpolated along the track; where the
    robot turns between two nodes, the correction turns with the raw track (an offset
    interpolated along it cuts the corner by millimetres).
    """
    node_xy = track[nodes.at, :2]
    p = track[:, :2]
    out = np.empty_like(track)
    pos = np.zeros_like(p)
    for node, weight in ((nodes.lo, 1.0 - nodes.w_xy), (nodes.lo + 1, nodes.w_xy)):
        c, s = np.cos(offsets[node, 2]), np.sin(offsets[node, 2])
        rel = p - node_xy[node]
        moved = np.column_stack((c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]))
        pos += weight[:, None] * (node_xy[node] + offsets[node, :2] + (1.0 + scale) * moved)
    out[:, :2] = pos
    turn = (1.0 - nodes.w) * offsets[nodes.lo, 2] + nodes.w * offsets[nodes.lo + 1, 2]
    out[:, 2] = _wrap(track[:, 2] + turn)
    return out


def _find_walls(rays: EchoRays, corrected: FloatArray) -> _Walls:
    """The walls under the corrected poses (N, 3), from the readings' tangent votes."""
    pose = corrected[rays.reading]
    xy, look = rays.sensors(pose[:, 0], pose[:, 1], pose[:, 2])
    geom = EchoGeometry(xy, look, rays.half_beam, rays.range_m)
    segs, _ = tangent_lines(geom, tol=WALL_TOL_M, min_votes=WALL_MIN_VOTES,
                            bridge_m=WALL_BRIDGE_M, min_spread_m=WALL_MIN_SPREAD_M)  # fmt: skip
    if not segs:
        z = np.zeros(0, dtype=np.intp)
        return _Walls(z, z.copy(), np.zeros((0, 2)), np.zeros(0))
    ray = np.concatenate([g.readings for g in segs]).astype(np.intp)
    wall = np.repeat(np.arange(len(segs)), [g.readings.size for g in segs]).astype(np.intp)
    centre = np.array([g.points.mean(axis=0) for g in segs])
    phi = np.array([math.atan2(g.normal[1], g.normal[0]) for g in segs])
    # near the axis only: an echo off the axis is weaker, and its range longer (time walk)
    incidence = np.abs(_wrap(look[ray] - phi[wall]))
    near = incidence <= AXIS_FRACTION * rays.half_beam[ray]
    return _Walls(ray[near], wall[near], centre, phi)


def _robust_echoes(first_echo: int) -> Callable[[FloatArray], FloatArray]:
    """A :func:`least_squares` loss: ``soft_l1`` (scale :data:`ROBUST_SCALE`) on the echo
    residuals from index ``first_echo`` on, squares on the odometry ties and the prior.

    An echo far off its wall is more likely another wall's than noise, so it costs
    linearly; an odometry tie is never an outlier (every step was driven), and a robust
    tie would let the map turn or stretch freely at one step to fit the echoes' noise.
    """
    s2 = ROBUST_SCALE**2

    def loss(z: FloatArray) -> FloatArray:
        out = np.empty((3, z.size))
        out[0], out[1], out[2] = z, 1.0, 0.0
        e = z[first_echo:] / s2
        t = np.sqrt(1.0 + e)
        out[0, first_echo:] = 2.0 * s2 * (t - 1.0)
        out[1, first_echo:] = 1.0 / t
        out[2, first_echo:] = -0.5 / (s2 * t**3)
        return out

    return loss


def _cost(prob: _WallProblem, x: FloatArray) -> float:
    """Half the sum of the loss of the residuals at ``x`` (what :func:`_solve` minimises)."""
    f = prob.residuals(x)
    return float(0.5 * np.sum(_robust_echoes(prob.first_echo)(f**2)[0]))


def _solve(prob: _WallProblem, x0: FloatArray, *, free_pose: bool,
           max_evaluations: int) -> tuple[FloatArray, int]:  # fmt: skip
    """Least squares from ``x0``: every unknown, or the walls alone (poses held)."""
    loss = _robust_echoes(prob.first_echo)
    if free_pose:
        res = least_squares(prob.residuals, x0, jac="2-point", jac_sparsity=prob.sparsity(),
                            method="trf", tr_solver="lsmr", loss=loss, max_nfev=max_evaluations,
                            x_scale="jac", diff_step=1e-7)  # fmt: skip
        return np.asarray(res.x, dtype=np.float64), int(res.nfev)
    head = x0[: prob.n_pose]

    def fun(walls: FloatArray) -> FloatArray:
        return prob.residuals(np.concatenate((head, walls)))

    res = least_squares(fun, x0[prob.n_pose :], jac="2-point",
                        jac_sparsity=prob.sparsity()[:, prob.n_pose :], method="trf",
                        tr_solver="lsmr", loss=loss, max_nfev=max_evaluations, x_scale="jac",
                        diff_step=1e-7)  # fmt: skip
    return np.concatenate((head, np.asarray(res.x, dtype=np.float64))), int(res.nfev)


def _lines_start(walls: _Walls) -> FloatArray:
    return np.concatenate((np.column_stack((walls.phi, np.zeros(walls.count))).ravel(), [0.0]))


def refine_alignment(
    readings: np.ndarray,
    sensors: np.ndarray,
    alignment: Alignment,
    *,
    speed_of_sound: float = DEFAULT_SPEED_OF_SOUND,
    node_spacing: float = 1.0,
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
    node_spacing, turn_radius, drift_fraction, heading_drift : float
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
    nodes = place_nodes(u, spacing=node_spacing, driven=driven)
    if nodes.count != alignment.node_offsets.shape[0]:
        raise ValueError("refine_alignment: the alignment's nodes do not fit these options")
    rays = echo_rays(readings, sensors, order, speed_of_sound=speed_of_sound)
    turned = np.concatenate(([0.0], np.cumsum(np.abs(_wrap(np.diff(track[:, 2]))))))
    ties = odometry_ties(
        track[nodes.at], np.diff(driven[nodes.at]), np.diff(turned[nodes.at]),
        drift_fraction=drift_fraction, heading_drift=heading_drift, turn_radius=turn_radius,
        position_floor=position_floor, heading_floor=heading_floor,
    )  # fmt: skip
    start = np.concatenate((alignment.node_offsets[1:].ravel(), alignment.calibration))
    walls = _find_walls(
        rays, blended_poses(track, nodes, alignment.node_offsets, float(alignment.calibration[0]))
    )
    if walls.count < 2:
        # one wall fixes neither the position along it nor the scale
        return Refinement(alignment, False, walls.count, int(walls.ray.size))
    first = _WallProblem(nodes, ties, rays, track, walls)
    x_before, evals = _solve(first, np.concatenate((start, _lines_start(walls))),
                             free_pose=False, max_evaluations=max_evaluations)  # fmt: skip
    x, pose = x_before, start
    prob = first
    for k in range(ROUNDS):
        if k > 0:
            off = np.vstack((np.zeros((1, 3)), pose[:-NCAL].reshape(-1, 3)))
            found = _find_walls(rays, blended_poses(track, nodes, off, float(pose[-NCAL])))
            if found.count < 2:
                break
            prob = _WallProblem(nodes, ties, rays, track, found)
            lines = _lines_start(found)
            lines[-1] = x[-1]  # the range delay found so far
            x, n = _solve(prob, np.concatenate((pose, lines)), free_pose=False,
                          max_evaluations=max_evaluations)  # fmt: skip
            evals += n
        x, n = _solve(prob, x, free_pose=True, max_evaluations=max_evaluations)
        evals += n
        pose = x[: prob.n_pose]
    pose = _placed_like(pose, alignment.node_offsets, track[nodes.at])
    # judged on the walls found at the accepted poses, their lines refitted to each
    cost_before = _cost(first, x_before)
    x_after, n = _solve(first, np.concatenate((pose, x_before[first.n_pose :])),
                        free_pose=False, max_evaluations=max_evaluations)  # fmt: skip
    evals += n
    cost_after = _cost(first, x_after)
    unknowns = first.n_pose
    drop = 2.0 * (cost_before - cost_after)
    threshold = float(chdtri(unknowns, SIGNIFICANCE))
    kept = bool(drop > threshold)
    log.info("alignment refinement %s: %d walls, %d echoes, twice the cost drop %.3g vs %.3g",
             "kept" if kept else "not kept", walls.count, walls.ray.size, drop,
             threshold)  # fmt: skip
    refined = alignment
    if kept:
        off = np.vstack((np.zeros((1, 3)), pose[:-NCAL].reshape(-1, 3)))
        refined = _with_offsets(alignment, track, order, nodes, off, pose[-NCAL:])
    return Refinement(refined, kept, walls.count, int(walls.ray.size), cost_before,
                      cost_after, drop, threshold, evals)  # fmt: skip


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
        heading_difference_max_rad=float(np.abs(_wrap(corrected[:, 2] - track[:, 2])).max()),
        calibration=calibration,
    )  # fmt: skip
