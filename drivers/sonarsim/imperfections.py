"""Sensor imperfections applied to ideal echoes. Pure functions; randomness is explicit.

Echoes here are parallel arrays: ``channel`` (which firing/receiver listened) and
``path`` (|TP| + |PR| in m). Ranges are half paths, as the Nomad reports them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sonarsim.geometry import FloatArray

INCH = 0.0254
"""The Nomad's range step (m)."""

IntArray = NDArray[np.intp]


def dropouts(n: int, probability: float, rng: np.random.Generator) -> NDArray[np.bool_]:
    """Keep-mask of ``n`` echoes, each lost independently with ``probability``.

    Examples
    --------
    >>> keep = dropouts(10_000, 0.25, np.random.default_rng(0))
    >>> bool(0.73 < keep.mean() < 0.77)
    True
    """
    if not 0.0 <= probability <= 1.0:
        raise ValueError(f"dropout probability must be in [0, 1], got {probability}")
    if probability == 0.0:
        return np.ones(n, dtype=bool)
    return np.asarray(rng.random(n) >= probability)


def spurious(
    min_range: FloatArray, max_range: FloatArray, probability: float, rng: np.random.Generator
) -> tuple[IntArray, FloatArray]:
    """Random false echoes: each channel gets one with ``probability``.

    Parameters
    ----------
    min_range, max_range : ndarray, shape (C,)
        Receiver range limits per channel (m).
    probability : float
        Chance that a channel gets a spurious echo.
    rng : numpy.random.Generator
        Random source.

    Returns
    -------
    channel : ndarray of intp
        Channels that got one.
    path : ndarray
        Their path lengths, twice a range drawn uniformly in the receiver's limits.
    """
    if not 0.0 <= probability <= 1.0:
        raise ValueError(f"spurious probability must be in [0, 1], got {probability}")
    c = min_range.size
    if probability == 0.0 or c == 0:
        return np.zeros(0, np.intp), np.zeros(0)
    hit = np.flatnonzero(rng.random(c) < probability)
    r = rng.uniform(min_range[hit], max_range[hit])
    return hit, 2.0 * r


def range_noise(path: FloatArray, sigma: float, rng: np.random.Generator) -> FloatArray:
    """Add zero-mean Gaussian noise of standard deviation ``sigma`` to each range.

    The range is half the path, so the path moves by twice the range noise.
    """
    if sigma < 0.0:
        raise ValueError(f"range noise sigma must be >= 0, got {sigma}")
    if sigma == 0.0:
        return path.copy()
    return np.asarray(path + 2.0 * rng.normal(0.0, sigma, path.shape), dtype=np.float64)


def quantise(path: FloatArray, step: float = INCH) -> FloatArray:
    """Round each range (half path) to a multiple of ``step`` (default 1 inch).

    Examples
    --------
    >>> quantise(np.array([2 * 0.0130, 2 * 0.0400]), 0.0254).round(4).tolist()
    [0.0508, 0.1016]
    """
    if step <= 0.0:
        raise ValueError(f"quantisation step must be > 0, got {step}")
    return np.asarray(2.0 * step * np.round(0.5 * path / step), dtype=np.float64)


def late_echoes(
    path: FloatArray, speed_of_sound: float, delay: FloatArray, window: FloatArray
) -> NDArray[np.bool_]:
    """Which echoes of a pulse land in a later listening window.

    An echo of path ``L`` from a pulse sent ``delay`` seconds before the window opened
    arrives ``L / c - delay`` seconds into that window; it is heard there when that time
    lies in ``[0, window)``.
    """
    arrival = path / speed_of_sound - delay
    return np.asarray((arrival >= 0.0) & (arrival < window))


def first_per_channel(channel: IntArray, path: FloatArray) -> IntArray:
    """Indices of the shortest path of each channel, ordered by channel."""
    if channel.size == 0:
        return np.zeros(0, np.intp)
    order = np.lexsort((path, channel))
    c = channel[order]
    first = np.ones(c.size, dtype=bool)
    first[1:] = c[1:] != c[:-1]
    return np.asarray(order[first], dtype=np.intp)
