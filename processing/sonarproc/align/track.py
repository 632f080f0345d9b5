"""The pose track as a curve: travel, correction nodes, and a correction along it.

A drift correction must be smooth along the track: odometry errors accumulate with
distance driven and angle turned, never jump. The track is therefore parametrised by
its *travel* ``u`` (distance driven plus ``turn_radius`` times the angle turned, so a
turn on the spot also moves along it); correction *nodes* sit every ``spacing`` of
travel, each holding an offset ``(dx, dy, dtheta)``; a reading's correction is the
linear interpolation of its two nodes' offsets: the heading offset's at its travel, the
position offset's at its distance driven (a position error grows only while the robot
drives: through a turn on the spot it stays as it was). The corrected pose adds the
offset to the raw pose (the heading offset turns the robot about its own centre).
The map-based refinement (:mod:`sonarproc.align.refine`) instead moves each raw position
rigidly with its two nodes' corrections (:func:`rigid_blend`, :func:`blended_poses`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "Nodes",
    "apply_offsets",
    "blended_poses",
    "interpolate_offsets",
    "place_nodes",
    "rigid_blend",
    "travel",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def wrap(angle: npt.ArrayLike) -> FloatArray:
    """Angles wrapped to [-pi, pi)."""
    a = np.asarray(angle, dtype=np.float64)
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def travel(x: FloatArray, y: FloatArray, theta: FloatArray, *, turn_radius: float) -> FloatArray:
    """Cumulative travel of a time-ordered track: distance plus ``turn_radius`` x turn.

    Examples
    --------
    >>> travel(np.array([0.0, 1.0, 1.0]), np.zeros(3), np.array([0.0, 0.0, np.pi / 2]),
    ...        turn_radius=0.5).round(3).tolist()
    [0.0, 1.0, 1.785]
    """
    if x.size == 0:
        return np.zeros(0)
    step = np.hypot(np.diff(x), np.diff(y)) + turn_radius * np.abs(wrap(np.diff(theta)))
    return np.concatenate(([0.0], np.cumsum(step)))


@dataclass(frozen=True, eq=False)
class Nodes:
    """Correction nodes along a track and each reading's place between two of them."""

    #: travel of each node (K,), increasing, first 0
    u: FloatArray
    #: the reading each node sits at (K,), an index into the time-ordered track
    at: IntArray
    #: for every reading, the node before it (N,), in 0 .. K - 2
    lo: IntArray
    #: for every reading, its weight on node ``lo + 1`` (N,), in [0, 1], by travel: the
    #: weight of the heading offset
    w: FloatArray
    #: the same by distance driven: the weight of the position offset
    w_xy: FloatArray
    #: travel and distance driven of every reading (N,)
    track_u: FloatArray
    track_d: FloatArray

    @property
    def count(self) -> int:
        """Number of nodes."""
        return int(self.u.size)

    def place(self, u: FloatArray) -> tuple[IntArray, FloatArray, FloatArray]:
        """Node before, heading weight and position weight at travels ``u`` (anywhere
        along the track, e.g. the mean travel of several readings)."""
        lo = np.clip(np.searchsorted(self.u, u, side="right") - 1, 0, max(self.count - 2, 0))
        if self.count < 2:
            z = np.zeros(np.shape(u))
            return lo.astype(np.intp), z, z.copy()
        w = np.clip((u - self.u[lo]) / (self.u[lo + 1] - self.u[lo]), 0.0, 1.0)
        node_d = np.interp(self.u, self.track_u, self.track_d)
        d = np.interp(u, self.track_u, self.track_d)
        return lo.astype(np.intp), w, _distance_weight(node_d, lo, d, w)


def _distance_weight(node_d: FloatArray, lo: IntArray, d: FloatArray, w: FloatArray) -> FloatArray:
    """Weight on node ``lo + 1`` by distance driven; by travel where the robot only turned
    between the two nodes (no distance to share out)."""
    span = node_d[lo + 1] - node_d[lo]
    moved = span > 1e-6
    by_d = (d - node_d[lo]) / np.where(moved, span, 1.0)
    return np.where(moved, np.clip(by_d, 0.0, 1.0), w)


def place_nodes(u: FloatArray, *, spacing: float, driven: FloatArray | None = None) -> Nodes:
    """Nodes about every ``spacing`` of travel (the first at the start, the last at the
    end), and each reading's interpolation between its two nodes.

    A track shorter than half a spacing gets a single node (nothing to correct).

    Odometry's position error grows only while the robot drives, its heading error
    also while it turns: a reading's position offset is therefore interpolated by the
    distance ``driven`` (cumulative, per reading; ``u`` when not given), its heading
    offset by travel. A turn on the spot between two nodes then keeps the position
    offset it started with instead of sliding it towards the next node's.

    Examples
    --------
    >>> n = place_nodes(np.array([0.0, 0.4, 1.0, 1.6, 2.2]), spacing=1.0)
    >>> n.u.tolist(), n.lo.tolist(), n.w.round(2).tolist()
    ([0.0, 1.1, 2.2], [0, 0, 0, 1, 1], [0.0, 0.36, 0.91, 0.45, 1.0])

    A robot that drives 0.5 m, turns on the spot (0.4 m of travel), then drives 0.5 m:
    through the turn its position weight stays at the end of the first drive.

    >>> u = np.array([0.0, 0.5, 0.7, 0.9, 1.4])
    >>> n = place_nodes(u, spacing=1.4, driven=np.array([0.0, 0.5, 0.5, 0.5, 1.0]))
    >>> n.w.round(2).tolist(), n.w_xy.round(2).tolist()
    ([0.0, 0.36, 0.5, 0.64, 1.0], [0.0, 0.5, 0.5, 0.5, 1.0])
    """
    if not spacing > 0:
        raise ValueError(f"spacing must be > 0, got {spacing}")
    total = float(u[-1]) if u.size else 0.0
    d = u if driven is None else driven
    if total < 0.5 * spacing:
        z = np.zeros(u.size, dtype=np.intp)
        return Nodes(np.zeros(1), np.zeros(1, dtype=np.intp), z, np.zeros(u.size),
                     np.zeros(u.size), u, d)  # fmt: skip
    # evenly spaced nodes, as close to ``spacing`` apart as a whole number of them allows
    node_u = np.linspace(0.0, total, max(round(total / spacing), 1) + 1)
    lo = np.clip(np.searchsorted(node_u, u, side="right") - 1, 0, node_u.size - 2)
    span = node_u[lo + 1] - node_u[lo]
    w = np.clip((u - node_u[lo]) / span, 0.0, 1.0)
    at = np.clip(np.searchsorted(u, node_u, side="left"), 0, u.size - 1).astype(np.intp)
    node_d = np.interp(node_u, u, d)
    w_xy = _distance_weight(node_d, lo, d, w)
    return Nodes(node_u, at, lo.astype(np.intp), w, w_xy, u, d)


def interpolate_offsets(
    offsets: FloatArray, lo: IntArray, w: FloatArray, w_xy: FloatArray | None = None
) -> FloatArray:
    """Per-reading offsets (N, 3) from node offsets (K, 3): heading by the weights ``w``
    on node ``lo + 1``, position by ``w_xy`` (``w`` when not given)."""
    wp = w if w_xy is None else w_xy
    out = (1.0 - w)[:, None] * offsets[lo] + w[:, None] * offsets[lo + 1]
    out[:, :2] = (1.0 - wp)[:, None] * offsets[lo, :2] + wp[:, None] * offsets[lo + 1, :2]
    return out


def apply_offsets(
    x: FloatArray, y: FloatArray, theta: FloatArray, offsets: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Corrected poses: raw poses plus their offsets (N, 3), heading wrapped."""
    return x + offsets[:, 0], y + offsets[:, 1], wrap(theta + offsets[:, 2])


def rigid_blend(
    p: FloatArray,
    node_xy: FloatArray,
    lo: IntArray,
    w: FloatArray,
    w_xy: FloatArray,
    offsets: FloatArray,
    grow: float,
) -> tuple[FloatArray, FloatArray]:
    """Positions ``p`` (N, 2) moved rigidly by their two nodes' corrections, and the turn.

    Each node's correction turns ``p`` about the node's raw position ``node_xy`` (K, 2) by
    its heading offset, scales it by ``grow`` and shifts it by its position offset
    (``offsets`` (K, 3)); the two are blended by the distance weight ``w_xy`` on node
    ``lo + 1``. The turn (N,) is the heading offsets blended by the travel weight ``w``.

    Moving the raw position rigidly, rather than adding an interpolated offset, follows
    the raw track's own bends: where the robot turns between two nodes the drift's offset
    turns with it (an offset interpolated along the track cuts the corner by millimetres,
    as much as the echoes can tell apart).

    Examples
    --------
    >>> offsets = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])
    >>> p = np.array([[0.5, 0.0]])
    >>> pos, turn = rigid_blend(p, np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0]),
    ...                         np.array([0.5]), np.array([0.5]), offsets, 1.0)
    >>> pos.round(3).tolist(), turn.tolist()
    ([[0.55, 0.0]], [0.0])
    """
    pos = np.zeros_like(p)
    for node, weight in ((lo, 1.0 - w_xy), (lo + 1, w_xy)):
        c, s = np.cos(offsets[node, 2]), np.sin(offsets[node, 2])
        rel = p - node_xy[node]
        moved = np.column_stack((c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]))
        pos += weight[:, None] * (node_xy[node] + offsets[node, :2] + grow * moved)
    turn = (1.0 - w) * offsets[lo, 2] + w * offsets[lo + 1, 2]
    return pos, np.asarray(turn, dtype=np.float64)


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
    out = np.empty_like(track)
    out[:, :2], turn = rigid_blend(
        track[:, :2], track[nodes.at, :2], nodes.lo, nodes.w, nodes.w_xy, offsets, 1.0 + scale
    )
    out[:, 2] = wrap(track[:, 2] + turn)
    return out
