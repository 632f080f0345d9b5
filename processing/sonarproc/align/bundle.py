"""The bundle adjustment of a map-based refinement: poses, walls and a range delay together.

:class:`WallProblem` holds the residuals (the pose graph's odometry ties and calibration
prior, then every near-axis echo's range residual to its wall, ``distance(sensor, wall)
- range``, in range deviations :data:`RANGE_SIGMA_M`) and the sparsity of their
Jacobian; :func:`solve_bundle` solves it by :func:`scipy.optimize.least_squares` with
the loss :func:`robust_echoes` (``soft_l1`` on the echoes, squares on the ties), every
unknown or the walls alone; :func:`bundle_cost` is the cost it minimises.

Each range is first rid of its time walk (:func:`wall_walk`). A threshold receiver times
an echo where its envelope crosses the threshold, so a weaker echo reads longer
(Kleeman & Kuc 1995): a plane's echo weakens as the square of the range, and off the
beam's axis as the main lobe's directivity, out and back. A wall's far echoes therefore
read millimetres longer than its near ones (0.2 mm head-on at 1 m, 3 mm at 4 m, more
than twice that half a beam off the axis), the same on every lap. Left in
the ranges, that error is what the adjustment fits best by bending and stretching the
track: on simulated transducer logs the ranges then agreed better with poses about a
centimetre off than with the true ones. It is not fitted per log: the ranges of walls
seen along a track hardly tell it from the walls' positions and the odometry's scale
(fitted, it came out 0 to 13 times the nominal walk and moved the poses further off),
so the nominal receiver's walk is used, as for a point's echoes
(:mod:`sonarproc.surfaces.reflectors.time_walk`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares
from scipy.sparse import csc_matrix, csr_matrix, diags

from sonarlog import DEFAULT_SPEED_OF_SOUND
from sonarproc.align.echoes import EchoRays
from sonarproc.align.graph import NCAL, ROBUST_SCALE, OdometryTies
from sonarproc.align.graph import PoseGraphProblem as _OdometryProblem
from sonarproc.align.matching import LineMatches
from sonarproc.align.track import Nodes, rigid_blend
from sonarproc.align.walls import Walls

__all__ = [
    "RANGE_SIGMA_M",
    "WallProblem",
    "bundle_cost",
    "bundle_costs",
    "echo_constrained_unknowns",
    "echo_dispersion",
    "lines_start",
    "robust_echoes",
    "solve_bundle",
    "wall_walk",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Standard deviation (m) of a first echo's range about its sensor's distance from a flat
#: wall: 1-inch range steps (2.54 cm / sqrt(12) = 0.73 cm) and a few millimetres of
#: timing noise, about 1 cm. A wrong association costs linearly beyond
#: ``ROBUST_SCALE`` of these (the loss is ``soft_l1``).
RANGE_SIGMA_M = 0.01


def _empty_matches() -> LineMatches:
    z2 = np.zeros((0, 2))
    return LineMatches(np.zeros(0, dtype=np.intp), z2, z2.copy(), np.zeros(0), z2.copy())


class WallProblem:
    """Residuals of the bundle adjustment (odometry, calibration, echoes) and which
    unknowns each depends on (for sparse finite differences)."""

    def __init__(self, nodes: Nodes, ties: OdometryTies, rays: EchoRays, track: FloatArray,
                 walls: Walls, *,
                 speed_of_sound: float = DEFAULT_SPEED_OF_SOUND) -> None:  # fmt: skip
        self.odometry = _OdometryProblem(nodes, ties, rays, track, _empty_matches(), 1.0)
        self.n_pose = 3 * (nodes.count - 1) + NCAL
        self.first_echo = 3 * (nodes.count - 1) + NCAL
        self.walls = walls
        self.rays = rays.subset(walls.ray)
        reading = self.rays.reading
        self.q_pose = track[reading]
        self.q_lo, self.q_w, self.q_wxy = nodes.lo[reading], nodes.w[reading], nodes.w_xy[reading]
        self.node_xy = ties.pose[:, :2]
        # the ranges less their time walk, its angle off the axis taken at the poses the
        # walls were found at (the adjustment turns a line of sight by a fraction of a
        # degree, which changes the walk by under 1 %)
        walk = wall_walk(self.rays.range_m, walls.incidence, self.rays.half_beam, speed_of_sound)
        self.range_m = self.rays.range_m - walk

    def split(self, params: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, float]:
        """Pose parameters, wall normal directions (L,), wall offsets (L,), range delay."""
        line = params[self.n_pose : -1].reshape(-1, 2)
        return params[: self.n_pose], line[:, 0], line[:, 1], float(params[-1])

    def _sensor(self, pose_params: FloatArray) -> FloatArray:
        """Sensor positions (M, 2): each reading's raw position moved rigidly (and scaled
        by the calibration) by its two nodes' corrections, blended by its weights
        (:func:`~sonarproc.align.track.rigid_blend`), its mount turned with it."""
        off = np.vstack((np.zeros((1, 3)), pose_params[:-NCAL].reshape(-1, 3)))
        grow = 1.0 + pose_params[-NCAL]
        pos, turn = rigid_blend(
            self.q_pose[:, :2], self.node_xy, self.q_lo, self.q_w, self.q_wxy, off, grow
        )
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
        r_echo = (reach - self.range_m + delay) / RANGE_SIGMA_M
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

    def jacobian(self, params: FloatArray, diff_step: float = 1e-7) -> csr_matrix:
        """The residuals' derivatives at ``params`` by forward differences (steps relative
        to ``max(1, |x|)``, as :func:`solve_bundle`'s), unknowns that share no residual
        stepped together (a few residual evaluations, not one per unknown)."""
        pattern = csc_matrix(self.sparsity())
        pattern.sum_duplicates()
        f0 = self.residuals(params)
        h = diff_step * np.maximum(1.0, np.abs(params))
        rows: list[IntArray] = []
        cols: list[IntArray] = []
        vals: list[FloatArray] = []
        for group in _column_groups(pattern):
            x = params.copy()
            x[group] += h[group]
            df = self.residuals(x) - f0
            for j in group:
                r = pattern.indices[pattern.indptr[j] : pattern.indptr[j + 1]]
                rows.append(r)
                cols.append(np.full(r.size, j, dtype=np.intp))
                vals.append(df[r] / h[j])
        data = (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols)))
        return csr_matrix(data, shape=pattern.shape)


def _column_groups(pattern: csc_matrix) -> list[IntArray]:
    """The columns of a sparsity pattern in groups that share no row, greedily in order
    (a node's offsets share residuals only with its neighbours' and the calibration's;
    different walls' lines share none)."""
    taken: list[npt.NDArray[np.bool_]] = []
    members: list[list[int]] = []
    for j in range(pattern.shape[1]):
        r = pattern.indices[pattern.indptr[j] : pattern.indptr[j + 1]]
        for mask, group in zip(taken, members, strict=True):
            if not mask[r].any():
                mask[r] = True
                group.append(j)
                break
        else:
            mask = np.zeros(pattern.shape[0], dtype=bool)
            mask[r] = True
            taken.append(mask)
            members.append([j])
    return [np.asarray(g, dtype=np.intp) for g in members]


def echo_constrained_unknowns(prob: WallProblem, x: FloatArray,
                              dispersion: float = 1.0) -> float:  # fmt: skip
    """How many of the pose unknowns the walls' echoes determine, at ``x``: the trace of
    the echoes' hat matrix, ``tr((T + E)^-1 E)``, the effective number of parameters of a
    fit with a prior (Hastie and Tibshirani's degrees of freedom of a linear smoother).

    ``T`` is the information of the odometry ties and the calibration prior on the pose
    unknowns, ``E`` the echoes' (each weighted as ``soft_l1`` weighs it at ``x``, their
    variance ``dispersion`` times the nominal one) with the walls' lines profiled out
    (they are refitted for every set of poses, so what the poses can explain by moving a
    wall does not count). An unknown the echoes determine far better than odometry
    counts one, one they hardly see counts nearly nothing: noise in the ranges can lower
    their cost only through the unknowns they determine. Near-axis echoes are mostly a
    side sonar's off the walls beside the track, so on the simulated transducer logs of
    the tests they determine a node's position across its track (0.8 of an unknown each)
    but hardly its position along it or its heading (0.1 each): about a third of the
    unknowns.
    """
    jac = prob.jacobian(x)
    f = prob.residuals(x)
    n_pose, first = prob.n_pose, prob.first_echo
    # soft_l1's weight (d rho / d z^2), over the echoes' variance in nominal ones
    weight = 1.0 / np.sqrt(1.0 + (f[first:] / ROBUST_SCALE) ** 2) / dispersion
    echo = csr_matrix(diags(np.sqrt(weight)) @ jac[first:])
    ties = jac[:first, :n_pose]
    # the lines' offsets span the range delay's column (one offset per wall, the delay
    # shifts them all), so the lines alone are profiled out
    n_lines = 2 * prob.walls.count
    pose, lines = echo[:, :n_pose], echo[:, n_pose : n_pose + n_lines]
    info = (pose.T @ pose).toarray()
    cross = (lines.T @ pose).toarray()
    gram = (lines.T @ lines).toarray()
    e = info - cross.T @ np.linalg.lstsq(gram, cross, rcond=None)[0]
    t = (ties.T @ ties).toarray()
    return float(np.trace(np.linalg.solve(t + e, e)))


def robust_echoes(first_echo: int) -> Callable[[FloatArray], FloatArray]:
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


def bundle_cost(prob: WallProblem, x: FloatArray) -> float:
    """Half the sum of the loss of the residuals at ``x`` (what :func:`solve_bundle` minimises)."""
    return sum(bundle_costs(prob, x))


def bundle_costs(prob: WallProblem, x: FloatArray) -> tuple[float, float]:
    """:func:`bundle_cost` in two parts: the odometry ties' and calibration prior's, and
    the echoes'."""
    f = prob.residuals(x)
    loss = robust_echoes(prob.first_echo)(f**2)[0]
    ties, echoes = loss[: prob.first_echo], loss[prob.first_echo :]
    return float(0.5 * np.sum(ties)), float(0.5 * np.sum(echoes))


def echo_dispersion(prob: WallProblem, x: FloatArray) -> float:
    """How widely the echoes scatter about their walls at ``x``, as a fraction of the
    nominal variance (:data:`RANGE_SIGMA_M` squared): their loss (``soft_l1``, the square
    of a residual in range deviations where it is small) per residual degree of freedom
    (echoes less the walls' and the poses' unknowns).

    :data:`RANGE_SIGMA_M` is a nominal figure, wide enough for 1-inch range steps; a
    log's own echoes say how widely its ranges scatter (on the simulated transducer logs
    of the tests 0.3 to 0.7 of that variance), and the chance level of a cost drop in
    nominal deviations scales with it.
    """
    f = prob.residuals(x)[prob.first_echo :]
    loss = robust_echoes(0)(f**2)[0]
    dof = f.size - (2 * prob.walls.count + 1) - prob.n_pose
    return float(np.sum(loss) / max(dof, 1))


def solve_bundle(prob: WallProblem, x0: FloatArray, *, free_pose: bool,
           max_evaluations: int) -> tuple[FloatArray, int]:  # fmt: skip
    """Least squares from ``x0``: every unknown, or the walls alone (poses held)."""
    loss = robust_echoes(prob.first_echo)
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


def lines_start(walls: Walls) -> FloatArray:
    """The start of the walls' unknowns: each line as found, no offset; no range delay."""
    return np.concatenate((np.column_stack((walls.phi, np.zeros(walls.count))).ravel(), [0.0]))


def wall_walk(range_m: FloatArray, incidence: FloatArray, half_beam: FloatArray,
              speed_of_sound: float = DEFAULT_SPEED_OF_SOUND) -> FloatArray:  # fmt: skip
    """Time walk (m) of a plane's echo at ``range_m`` whose normal lies ``incidence`` (rad)
    off the beam's axis: how much longer than the distance the receiver reads it.

    The nominal receiver's walk (:func:`sonarsim.transducer.time_walk`, the Polaroid
    ranging board's rise time and threshold) of the plane's echo amplitude, the main lobe's
    directivity out and back times the spreading as the square of the range
    (:func:`sonarsim.transducer.main_lobe_amplitude`); ``ka`` from the nominal half beam
    width taken as the piston's first null (``ka sin(half_beam) = 3.8317``), as elsewhere
    in the processing.

    Examples
    --------
    Head-on at 1 m and 4 m, and 6 degrees off the axis at 4 m (12.5 degree half width):

    >>> walk = wall_walk(np.array([1.0, 4.0, 4.0]), np.radians([0.0, 0.0, 6.0]),
    ...                  np.radians(np.full(3, 12.5)), 343.0)
    >>> (1000 * walk).round(2).tolist()
    [0.21, 3.34, 7.87]
    """
    from sonarsim.transducer import (
        PISTON_FIRST_NULL,
        TransducerParams,
        main_lobe_amplitude,
        time_walk,
    )

    ka = PISTON_FIRST_NULL / np.sin(np.clip(half_beam, 1e-3, 0.5 * np.pi))
    theta = np.abs(incidence)
    amp = main_lobe_amplitude(theta, theta, np.maximum(range_m, 1e-3), ka)
    return np.asarray(time_walk(amp, TransducerParams(), speed_of_sound), dtype=np.float64)
