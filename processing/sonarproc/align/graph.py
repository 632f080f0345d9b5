"""The pose graph: node offsets tied by odometry, pulled together by matched echoes.

Unknowns: the offset ``(dx, dy, dtheta)`` of every correction node but the first (the
first fixes the world frame: the corrected track starts where the raw one does), and
two odometry calibration errors, the systematic part of drift (Borenstein and Feng's
UMBmark: an average wheel diameter off, unequal wheel diameters):

* ``scale``: the fraction by which every distance driven is off;
* ``heading_rate``: heading error per metre driven (rad/m, a robot that curves when
  it should drive straight).

A third, a turn scale (a wheel base off), is not estimated: on a loop it rotates the
track as much per lap as a heading rate does, so the echoes cannot tell the two apart
and the solution would trade one for the other; the random heading error per radian
turned (see :func:`odometry_ties`) covers it.

Residuals, each divided by its standard deviation:

* odometry, between consecutive nodes: the corrected relative motion (in the first
  node's frame) minus the raw one as calibrated (scaled, and turned by half the heading
  drift over the step: a robot whose heading drifts drives a curve, whose chord points
  half the drift off its starting heading), position and heading; their deviations
  (the random part of drift) grow with the distance driven and the angle turned;
* calibration: each calibration error over a broad prior (5 %, 5 degrees per 10 m),
  which only matters where the echoes cannot tell (a single straight corridor);
* echoes, the specular model: a matched query reading, under its own correction, should
  lie at its range from its matched wall (moved by the correction of the wall's own
  stretch); the residual is the wall's distance from the query's sensor minus the range
  (the distance of its specular echo point, sensor + range along the wall's normal,
  from the wall).

Solved by :func:`scipy.optimize.least_squares` (trust region, a robust ``soft_l1`` loss
so that wrong matches cost linearly, and the sparse Jacobian in closed form: each
residual involves at most four nodes and the calibration).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix, csr_matrix

from sonarproc.align.echoes import EchoRays
from sonarproc.align.matching import LineMatches
from sonarproc.align.track import Nodes, interpolate_offsets

__all__ = [
    "CALIBRATION_PRIOR",
    "CorrectionCosts",
    "GraphSolution",
    "OdometryTies",
    "PoseGraphProblem",
    "correction_costs",
    "odometry_ties",
    "solve_graph",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Residuals are in standard deviations; beyond this many the loss grows linearly (a
#: residual that large is more likely a wrong match than noise).
ROBUST_SCALE = 2.0
#: Prior deviations of (scale, heading_rate): broad, several times the systematic
#: errors of an uncalibrated differential drive.
CALIBRATION_PRIOR = np.array([0.05, math.radians(5.0) / 10.0])
#: Number of calibration unknowns.
NCAL = CALIBRATION_PRIOR.size


@dataclass(frozen=True, eq=False)
class OdometryTies:
    """Raw relative motion between consecutive nodes and its standard deviations."""

    #: raw node poses (K, 3): x, y, theta
    pose: FloatArray
    #: raw motion from node k to k + 1 in node k's frame (K - 1, 2)
    step_xy: FloatArray
    #: distance driven between the nodes (K - 1,)
    driven: FloatArray
    #: standard deviations (K - 1,) of position (m) and heading (rad) of each step
    sigma_xy: FloatArray
    sigma_theta: FloatArray


@dataclass(frozen=True, eq=False)
class GraphSolution:
    """Node offsets (K, 3), calibration (2,), the robust cost at zero and at the end."""

    offsets: FloatArray
    calibration: FloatArray
    cost_before: float
    cost_after: float
    evaluations: int


def odometry_ties(
    pose: FloatArray, driven: FloatArray, turned: FloatArray, *,
    drift_fraction: float, heading_drift: float, turn_radius: float,
    position_floor: float, heading_floor: float,
) -> OdometryTies:  # fmt: skip
    """Relative motions between nodes and how far odometry may have erred on each.

    ``driven`` and ``turned`` (K - 1,) are the distance (m) and the total absolute turn
    (rad) between consecutive nodes.
    """
    d = np.diff(pose[:, :2], axis=0)
    c, s = np.cos(pose[:-1, 2]), np.sin(pose[:-1, 2])
    step = np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]))
    sig_xy = drift_fraction * driven + position_floor
    sig_th = heading_drift * (driven + turn_radius * turned) + heading_floor
    return OdometryTies(pose, step, driven, sig_xy, sig_th)


def _split(params: FloatArray) -> tuple[FloatArray, FloatArray]:
    return np.vstack((np.zeros((1, 3)), params[:-NCAL].reshape(-1, 3))), params[-NCAL:]


def _rotate(v: FloatArray, c: FloatArray, s: FloatArray) -> FloatArray:
    return np.column_stack((c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]))


def _perp(v: FloatArray) -> FloatArray:
    return np.column_stack((-v[:, 1], v[:, 0]))


def _bent(t: OdometryTies, heading_rate: float) -> FloatArray:
    """The raw steps turned by half the heading drift over them: a robot whose heading
    drifts at ``heading_rate`` per metre curves, so the chord of a step of ``driven``
    metres points ``heading_rate * driven / 2`` off the heading at its start."""
    a = 0.5 * heading_rate * t.driven
    return _rotate(t.step_xy, np.cos(a), np.sin(a))


class PoseGraphProblem:
    """Residuals and Jacobian of one round's matches (kept between calls)."""

    def __init__(self, nodes: Nodes, ties: OdometryTies, rays: EchoRays, track: FloatArray,
                 matches: LineMatches, echo_sigma: float) -> None:  # fmt: skip
        self.nodes, self.ties, self.echo_sigma = nodes, ties, echo_sigma
        self.rays = rays.subset(matches.query)
        reading = self.rays.reading
        self.q_pose = track[reading]
        self.q_lo, self.q_w, self.q_wxy = nodes.lo[reading], nodes.w[reading], nodes.w_xy[reading]
        self.a_lo, self.a_w, self.a_wxy = nodes.place(matches.anchor_u)
        self.m = matches

    def _geometry(self, off: FloatArray) -> dict[str, FloatArray]:
        """Everything the residuals and their derivatives share."""
        t = self.ties
        pc = t.pose + off
        d = np.diff(pc[:, :2], axis=0)
        c, s = np.cos(pc[:-1, 2]), np.sin(pc[:-1, 2])
        step = np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]))
        oq = interpolate_offsets(off, self.q_lo, self.q_w, self.q_wxy)
        turret = self.q_pose[:, 2] + oq[:, 2] + self.rays.turret_offset
        arm = _rotate(self.rays.mount, np.cos(turret), np.sin(turret))
        sensor = self.q_pose[:, :2] + oq[:, :2] + arm
        oa = interpolate_offsets(off, self.a_lo, self.a_w, self.a_wxy)
        ca, sa = np.cos(oa[:, 2]), np.sin(oa[:, 2])
        normal = _rotate(self.m.normal, ca, sa)
        rel = _rotate(self.m.centroid - self.m.anchor_xy, ca, sa)
        centre = self.m.anchor_xy + oa[:, :2] + rel
        return {"c": c, "s": s, "step": step, "arm": arm, "sensor": sensor,
                "normal": normal, "rel": rel, "centre": centre}  # fmt: skip

    def residuals(self, params: FloatArray) -> FloatArray:
        off, cal = _split(params)
        t, g = self.ties, self._geometry(off)
        r_xy = (g["step"] - (1.0 + cal[0]) * _bent(t, cal[1])) / t.sigma_xy[:, None]
        turn = np.diff(off[:, 2]) - cal[1] * t.driven
        r_th = turn / t.sigma_theta
        reach = np.sum(g["normal"] * (g["centre"] - g["sensor"]), axis=1)
        r_echo = (reach - self.rays.range_m) / self.echo_sigma
        return np.concatenate((r_xy.ravel(), r_th, cal / CALIBRATION_PRIOR, r_echo))

    def jacobian(self, params: FloatArray) -> csr_matrix:
        """The residuals' derivatives, in closed form (sparse)."""
        off, cal = _split(params)
        t, g, k = self.ties, self._geometry(off), self.nodes.count
        n_odo, n_par = k - 1, 3 * (k - 1) + NCAL
        rows: list[IntArray] = []
        cols: list[IntArray] = []
        vals: list[FloatArray] = []

        def add(row: IntArray, node: IntArray, comp: int, value: FloatArray) -> None:
            # node 0 is fixed (no column); duplicates are summed by the sparse matrix
            ok = node > 0
            rows.append(row[ok])
            cols.append(3 * (node[ok] - 1) + comp)
            vals.append(np.broadcast_to(value, row.shape)[ok])

        def add_cal(row: IntArray, which: int, value: FloatArray) -> None:
            rows.append(row)
            cols.append(np.full(row.size, n_par - NCAL + which, dtype=np.intp))
            vals.append(np.broadcast_to(value, row.shape))

        # odometry: step = R(-theta_k') (p_{k+1}' - p_k'); d step / d phi_k = (step_y, -step_x)
        kk = np.arange(n_odo)
        c, s, step = g["c"], g["s"], g["step"]
        rot = ((c, s), (-s, c))
        bent = _bent(t, cal[1])
        bent_perp = _perp(bent)
        for i in range(2):
            row = 2 * kk + i
            for j in range(2):
                add(row, kk + 1, j, rot[i][j] / t.sigma_xy)
                add(row, kk, j, -rot[i][j] / t.sigma_xy)
            add(row, kk, 2, (step[:, 1] if i == 0 else -step[:, 0]) / t.sigma_xy)
            add_cal(row, 0, -bent[:, i] / t.sigma_xy)
            add_cal(row, 1, -(1.0 + cal[0]) * 0.5 * t.driven * bent_perp[:, i] / t.sigma_xy)
        row = 2 * n_odo + kk
        add(row, kk + 1, 2, 1.0 / t.sigma_theta)
        add(row, kk, 2, -1.0 / t.sigma_theta)
        add_cal(row, 1, -t.driven / t.sigma_theta)
        for which in range(NCAL):
            prior = 1.0 / CALIBRATION_PRIOR[which : which + 1]
            add_cal(np.array([3 * n_odo + which]), which, prior)
        # echoes: f = n' . (centre' - sensor') - range
        normal, gap = g["normal"], g["centre"] - g["sensor"]
        e = 1.0 / self.echo_sigma
        dq = (-normal[:, 0] * e, -normal[:, 1] * e, -np.sum(normal * _perp(g["arm"]), axis=1) * e)
        turn_a = np.sum(_perp(normal) * gap, axis=1) + np.sum(normal * _perp(g["rel"]), axis=1)
        da = (normal[:, 0] * e, normal[:, 1] * e, turn_a * e)
        row = 3 * n_odo + NCAL + np.arange(self.m.size)
        for comp in range(3):
            qw, aw = (self.q_w, self.a_w) if comp == 2 else (self.q_wxy, self.a_wxy)
            add(row, self.q_lo, comp, (1.0 - qw) * dq[comp])
            add(row, self.q_lo + 1, comp, qw * dq[comp])
            add(row, self.a_lo, comp, (1.0 - aw) * da[comp])
            add(row, self.a_lo + 1, comp, aw * da[comp])
        shape = (3 * n_odo + NCAL + self.m.size, n_par)
        jac = coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=shape)  # fmt: skip
        return jac.tocsr()


def robust_cost(residuals: FloatArray) -> float:
    """The ``soft_l1`` cost :func:`least_squares` minimises, for given residuals."""
    z = (residuals / ROBUST_SCALE) ** 2
    return float(0.5 * ROBUST_SCALE**2 * np.sum(2.0 * (np.sqrt(1.0 + z) - 1.0)))


@dataclass(frozen=True)
class CorrectionCosts:
    """A correction judged on given matches: without it (``before``) and with it.

    ``cost_*``: the robust cost :func:`solve_graph` minimises (odometry ties, calibration
    prior and echo residuals); ``median_*_m``: the median absolute echo residual (m), the
    typical echo's disagreement with its matched wall, which the robust cost does not
    show apart from its few large residuals.
    """

    cost_before: float
    cost_after: float
    median_before_m: float
    median_after_m: float


def correction_costs(
    nodes: Nodes, ties: OdometryTies, rays: EchoRays, track: FloatArray,
    matches: LineMatches, offsets: FloatArray, calibration: FloatArray, *, echo_sigma: float,
) -> CorrectionCosts:  # fmt: skip
    """The robust cost and the median echo residual on given matches, without a
    correction and with the given one, evaluated without solving: a correction found on
    one set of matches can be judged on another."""
    prob = PoseGraphProblem(nodes, ties, rays, track, matches, echo_sigma)
    x = np.concatenate((np.asarray(offsets[1:], dtype=np.float64).ravel(), calibration))
    before, after = prob.residuals(np.zeros_like(x)), prob.residuals(x)
    n = matches.size
    if n == 0:
        med_before = med_after = 0.0
    else:  # the echo residuals are the last n, in units of echo_sigma
        med_before = float(np.median(np.abs(before[-n:]) * echo_sigma))
        med_after = float(np.median(np.abs(after[-n:]) * echo_sigma))
    return CorrectionCosts(robust_cost(before), robust_cost(after), med_before, med_after)


def solve_graph(
    nodes: Nodes, ties: OdometryTies, rays: EchoRays, track: FloatArray,
    matches: LineMatches, start: FloatArray, calibration: FloatArray, *,
    echo_sigma: float, max_evaluations: int,
) -> GraphSolution:  # fmt: skip
    """Node offsets and calibration that best agree with odometry and matched echoes.

    Parameters
    ----------
    nodes, ties : Nodes, OdometryTies
        The correction nodes and the odometry between them.
    rays : EchoRays
        All rays; ``matches.query`` indexes them.
    track : ndarray, shape (N, 3)
        Raw poses of the time-ordered track.
    matches : LineMatches
        This round's echo matches.
    start : ndarray, shape (K, 3)
        Node offsets to start from (the first row is ignored: it stays zero).
    calibration : ndarray, shape (2,)
        Calibration errors to start from (scale, heading rate).
    echo_sigma : float
        Standard deviation (m) of an echo point about its wall.
    max_evaluations : int
        Residual evaluations allowed.
    """
    # imported here: a track whose echoes match too few other stretches is left as it
    # is without a solve, and scipy.optimize is a tenth of a second of a fresh start
    from scipy.optimize import least_squares

    prob = PoseGraphProblem(nodes, ties, rays, track, matches, echo_sigma)
    x0 = np.concatenate((np.asarray(start[1:], dtype=np.float64).ravel(), calibration))
    before = robust_cost(prob.residuals(np.zeros_like(x0)))
    res = least_squares(
        prob.residuals, x0, jac=prob.jacobian, method="trf", tr_solver="lsmr",
        loss="soft_l1", f_scale=ROBUST_SCALE, max_nfev=max_evaluations, x_scale="jac",
    )  # fmt: skip
    x = np.asarray(res.x, dtype=np.float64)
    off, cal = _split(x)
    return GraphSolution(off, cal, before, robust_cost(prob.residuals(x)), int(res.nfev))
