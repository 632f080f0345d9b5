"""Small vectorised 2-D geometry helpers shared by the simulator modules."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """Wrap angles to ``[-pi, pi)``.

    Parameters
    ----------
    angle : array_like
        Angles in radians.

    Returns
    -------
    ndarray
        The same angles wrapped to ``[-pi, pi)``.

    Examples
    --------
    >>> float(wrap_angle(3 * np.pi / 2))
    -1.5707963267948966
    """
    a = np.asarray(angle, dtype=np.float64)
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def unit(v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Split ``(..., 2)`` vectors into unit vectors and their lengths.

    Zero vectors give a zero unit vector (no division warning).
    """
    n = np.hypot(v[..., 0], v[..., 1])
    safe = np.where(n > 0.0, n, 1.0)
    return v / safe[..., None], n


def perp(v: FloatArray) -> FloatArray:
    """Rotate ``(..., 2)`` vectors by +90 degrees."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def heading_vectors(heading: ArrayLike) -> FloatArray:
    """Unit vectors ``(..., 2)`` pointing along ``heading`` (rad, CCW from +x)."""
    h = np.asarray(heading, dtype=np.float64)
    return np.stack([np.cos(h), np.sin(h)], axis=-1)


def rotate(xy: ArrayLike, angle: ArrayLike) -> FloatArray:
    """Rotate ``(..., 2)`` points about the origin by ``angle`` (broadcast)."""
    p = np.asarray(xy, dtype=np.float64)
    a = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * p[..., 0] - s * p[..., 1], s * p[..., 0] + c * p[..., 1]], axis=-1)


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """z component of the cross product of ``(..., 2)`` vectors."""
    return np.asarray(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0], dtype=np.float64)


def dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """Dot product over the last axis of ``(..., 2)`` vectors."""
    return np.asarray(a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1], dtype=np.float64)
