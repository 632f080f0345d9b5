"""The pose track as a curve: travel, correction nodes, and a correction along it.

A drift correction must be smooth along the track: odometry errors accumulate with
distance driven and angle turned, never jump. The track is therefore parametrised by
its *travel* ``u`` (distance driven plus ``turn_radius`` times the angle turned, so a
turn on the spot also moves along it); correction *nodes* sit every ``spacing`` of
travel, each holding an offset ``(dx, dy, dtheta)``; a reading's correction is the
linear interpolation of its two nodes' offsets at its travel. The corrected pose adds
the offset to the raw pose (the heading offset turns the robot about its own centre).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Nodes", "apply_offsets", "interpolate_offsets", "place_nodes", "travel"]

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
    #: for every reading, its weight on node ``lo + 1`` (N,), in [0, 1]
    w: FloatArray

    @property
    def count(self) -> int:
        """Number of nodes."""
        return int(self.u.size)


def place_nodes(u: FloatArray, *, spacing: float) -> Nodes:
    """Nodes about every ``spacing`` of travel (the first at the start, the last at the
    end), and each reading's interpolation between its two nodes.

    A track shorter than half a spacing gets a single node (nothing to correct).

    Examples
    --------
    >>> n = place_nodes(np.array([0.0, 0.4, 1.0, 1.6, 2.2]), spacing=1.0)
    >>> n.u.tolist(), n.lo.tolist(), n.w.round(2).tolist()
    ([0.0, 1.1, 2.2], [0, 0, 0, 1, 1], [0.0, 0.36, 0.91, 0.45, 1.0])
    """
    if not spacing > 0:
        raise ValueError(f"spacing must be > 0, got {spacing}")
    total = float(u[-1]) if u.size else 0.0
    if total < 0.5 * spacing:
        z = np.zeros(u.size, dtype=np.intp)
        return Nodes(np.zeros(1), np.zeros(1, dtype=np.intp), z, np.zeros(u.size))
    # evenly spaced nodes, as close to ``spacing`` apart as a whole number of them allows
    node_u = np.linspace(0.0, total, max(round(total / spacing), 1) + 1)
    lo = np.clip(np.searchsorted(node_u, u, side="right") - 1, 0, node_u.size - 2)
    span = node_u[lo + 1] - node_u[lo]
    w = np.clip((u - node_u[lo]) / span, 0.0, 1.0)
    at = np.clip(np.searchsorted(u, node_u, side="left"), 0, u.size - 1).astype(np.intp)
    return Nodes(node_u, at, lo.astype(np.intp), w)


def interpolate_offsets(offsets: FloatArray, lo: IntArray, w: FloatArray) -> FloatArray:
    """Per-reading offsets (N, 3) from node offsets (K, 3)."""
    return (1.0 - w)[:, None] * offsets[lo] + w[:, None] * offsets[lo + 1]


def apply_offsets(
    x: FloatArray, y: FloatArray, theta: FloatArray, offsets: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Corrected poses: raw poses plus their offsets (N, 3), heading wrapped."""
    return x + offsets[:, 0], y + offsets[:, 1], wrap(theta + offsets[:, 2])
