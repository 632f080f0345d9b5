"""The association rounds of the pose graph: match echoes, solve, match again.

:func:`association_rounds` alternates matching echo points to other stretches' lines
(:mod:`~sonarproc.align.matching`) with solving the pose graph
(:mod:`~sonarproc.align.graph`), the match radius shrinking, until the correction
settles; it stops early when a round's matches are too few for the nodes' unknowns.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.align.echoes import EchoRays
from sonarproc.align.graph import NCAL, OdometryTies, solve_graph
from sonarproc.align.matching import LineMatches, RayFrame, line_matches, match_lines
from sonarproc.align.track import Nodes, interpolate_offsets

__all__ = ["RoundsContext", "RoundsResult", "association_rounds"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class RoundsContext:
    """What every association round of one log shares."""

    nodes: Nodes
    ties: OdometryTies
    rays: EchoRays
    track: FloatArray
    ray_pose: FloatArray
    raw: RayFrame
    stretch: npt.NDArray[np.intp]


@dataclass(frozen=True, eq=False)
class RoundsResult:
    """The outcome of the association rounds: the correction and its matches."""

    offsets: FloatArray
    calibration: FloatArray
    matched: int
    short: bool  # whether a round found too few matches
    rounds: int
    evaluations: int
    first_matches: LineMatches | None


def association_rounds(
    c: RoundsContext, queries: npt.NDArray[np.intp], need: int, *, far_only: bool, rounds: int,
    match_radius: tuple[float, float], min_points: int, min_places: int, echo_sigma: float,
    max_evaluations: int,
) -> RoundsResult:  # fmt: skip
    """Match the ``queries`` rays and solve, ``rounds`` times at most (see
    :func:`~sonarproc.align.align_poses`); stops when a round finds fewer than ``need``
    matches (only those between stretches that are not neighbours when ``far_only``).

    Parameters
    ----------
    c : RoundsContext
        The nodes, odometry ties, rays and raw poses of the log.
    queries : ndarray of int
        The rays matched in every round.
    need : int
        Fewest matches a round must find to be solved.
    far_only : bool
        Count only matches between stretches at least two nodes apart.
    rounds, match_radius, min_points, min_places, echo_sigma, max_evaluations
        As given to :func:`~sonarproc.align.align_poses`.

    Returns
    -------
    RoundsResult
        The node offsets and calibration of the last solve (zero when none), the last
        round's match count (as counted), whether a round fell short, the rounds solved,
        the residual evaluations, and the first round's matches (found at the raw poses).
    """
    nodes, rays, ray_pose = c.nodes, c.rays, c.ray_pose
    offsets = np.zeros((nodes.count, 3))
    calibration = np.zeros(NCAL)
    first, last = match_radius
    done = evaluations = matched = 0
    first_matches, short = None, False
    for k in range(rounds):
        radius = max(last, first * (last / first) ** (k / max(rounds // 2, 1)))
        if k == 0:  # no correction yet: the raw frame (a long log is often declined here)
            pts, look = c.raw.points, c.raw.look
        else:
            at = rays.reading
            o = interpolate_offsets(offsets, nodes.lo[at], nodes.w[at], nodes.w_xy[at])
            now = (ray_pose[:, 0] + o[:, 0], ray_pose[:, 1] + o[:, 1], ray_pose[:, 2] + o[:, 2])
            pts, look = rays.points(*now), rays.sensors(*now)[1]
        query, nbrs = match_lines(pts, c.stretch, queries, radius=radius,
                                  min_points=min_points, max_thickness=echo_sigma)  # fmt: skip
        if query.size == 0:
            break
        matches = line_matches(
            query, nbrs, c.raw, look[query], min_points=min_points, min_places=min_places
        )
        counted = _far_matches(matches, nodes, c.stretch) if far_only else matches.size
        if counted < need:
            # each node has three unknowns: with fewer echo constraints than a few per
            # unknown, chance matches would decide the correction, not the walls
            matched, short = counted, True
            break
        if first_matches is None:
            first_matches = matches
        sol = solve_graph(nodes, c.ties, rays, c.track, matches, offsets, calibration,
                          echo_sigma=echo_sigma, max_evaluations=max_evaluations)  # fmt: skip
        done, evaluations, matched = k + 1, evaluations + sol.evaluations, matches.size
        moved = _largest_move(sol.offsets - offsets)
        offsets, calibration = sol.offsets, sol.calibration
        log.debug("alignment round %d: radius %.3f m, %d matches, moved %.4f m",
                  k + 1, radius, matches.size, moved)  # fmt: skip
        if moved < 1e-3 and radius <= last:
            break
    return RoundsResult(offsets, calibration, matched, short, done, evaluations, first_matches)


def _far_matches(matches: LineMatches, nodes: Nodes, stretch: npt.NDArray[np.intp]) -> int:
    """Matches between stretches of track that are not neighbours: those observe the
    drift accumulated between them, while a match into the next stretch along one wall
    ties two consecutive nodes as odometry does, and observes only the drift over a
    node spacing (a few centimetres at most, an echo's noise)."""
    other = nodes.place(matches.anchor_u)[0]
    return int(np.count_nonzero(np.abs(stretch[matches.query] - other) >= 2))


def _largest_move(change: FloatArray) -> float:
    """Largest move of a node by an offset change, its turn counted as at 1 m range."""
    return float(np.max(np.hypot(change[:, 0], change[:, 1]) + np.abs(change[:, 2])))
