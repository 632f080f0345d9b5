"""Stale sonar values: a value republished without a new firing.

Drivers such as RosAria and Player's p2os publish the whole ring every cycle, but the
robot fires its sonars in turn, so most values in a cycle are the same bits as that
sonar's previous message. Such a repeat is dropped. The rule is deliberately strict
(bit-for-bit equality with the same sensor's previous value, robot moving or not):

* a stale value kept at a new pose would put an arc where there is no surface;
* a true new firing that happens to give the same bits (a side sonar running along a
  parallel wall) is dropped too, but its predecessor already says the same thing.

>>> sensor = np.array([0, 1, 0, 1, 0])
>>> value = np.array([1.5, 2.0, 1.5, 2.5, 1.25])
>>> stale_mask(sensor, value_key(value)).tolist()
[False, False, True, False, False]
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["stale_mask", "value_key"]


def value_key(*values: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """A hashable integer per row from the exact bits of one or two float columns.

    Each column is compared as float32, the width of every ROS and Player range field, so
    a value that went through float64 and back compares equal to itself.
    """
    with np.errstate(over="ignore"):  # a value beyond float32 compares as its infinity
        cols = [np.asarray(v, dtype=np.float32).view(np.uint32).astype(np.int64) for v in values]
    if len(cols) == 1:
        return cols[0]
    if len(cols) == 2:
        return (cols[0] << 32) ^ cols[1]
    raise ValueError("value_key takes one or two columns")


def stale_mask(sensor: npt.ArrayLike, key: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """True where a value repeats its sensor's previous value exactly.

    Parameters
    ----------
    sensor : array_like of int
        Transducer of each value, in message order.
    key : array_like of int
        The value's bits (see :func:`value_key`).

    Returns
    -------
    numpy.ndarray of bool
        The stale values (a sensor's first value is never stale).
    """
    s = np.asarray(sensor)
    k = np.asarray(key)
    order = np.argsort(s, kind="stable")  # stable: message order within each sensor
    ss, kk = s[order], k[order]
    rep = np.zeros(s.size, dtype=bool)
    rep[1:] = (ss[1:] == ss[:-1]) & (kk[1:] == kk[:-1])
    out = np.empty_like(rep)
    out[order] = rep
    return out
