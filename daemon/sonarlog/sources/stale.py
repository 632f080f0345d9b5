"""Stale sonar values: a value republished without a new firing.

Drivers such as RosAria and Player's p2os publish the whole ring every cycle, but the
robot fires its sonars in turn, so most values in a cycle are the same bits as that
sonar's previous message. Such a repeat is dropped. The rule is deliberately strict
(bit-for-bit equality with the same sensor's previous value, robot moving or not):

* a stale value kept at a new pose would put an arc where there is no surface;
* a true new firing that happens to give the same bits (a side sonar running along a
  parallel wall, a range quantised to an inch) would be dropped too, and a quantised
  sonar repeats often: half the readings of a ring driving past a gentle wall. One case
  tells them apart: a message that holds the whole ring (a Player sonar line, a RosAria
  cloud) is sent because a transducer fired, so when none of its values changed, the one
  whose turn it was fired with the same range (:func:`refired_mask`).

>>> sensor = np.array([0, 1, 0, 1, 0])
>>> value = np.array([1.5, 2.0, 1.5, 2.5, 1.25])
>>> stale_mask(sensor, value_key(value)).tolist()
[False, False, True, False, False]
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["refired_mask", "stale_mask", "value_key"]

#: A transducer fires once per ring cycle, a whole number of cycles after its last firing;
#: a quiet message is credited to the transducer due within this fraction of the spacing
#: between two firings (the cycle over the ring's transducers): half the spacing is the
#: most that still names one transducer.
PHASE_TOLERANCE = 0.5


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


def refired_mask(
    sensor: npt.ArrayLike, t: npt.ArrayLike, stale: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """Repeats that are new firings: in a whole-ring message where no value changed.

    A driver that sends every transducer's latest value in one message (Player's sonar
    lines, RosAria's clouds) sends it when the robot reports a firing. A message of two or
    more values, all of them repeats (a *quiet* message), therefore still carries one
    firing whose range did not change. A ring fires its transducers in a fixed sequence,
    each once per cycle, so the firing is credited to the transducer whose place in the
    cycle is the message's:

    * the cycle is the shortest interval between two changed values of one transducer
      (each transducer fires at most once per cycle; one that hears an echo on every
      cycle shows the cycle itself);
    * a transducer's next firing is due a whole number of cycles after its last reading
      (its phase follows the latest firing, so a sequence that shifts, at a stop or a
      turn, is followed);
    * the quiet message goes to the transducer whose due time is nearest to the
      message's, when it is within :data:`PHASE_TOLERANCE` of the spacing between two
      firings (the cycle over the transducers in the messages) and that transducer's
      last reading is at least half a cycle old.

    Messages are the runs of values sharing one stamp. Transducers that never changed
    (never fired) are never credited, and a transducer's first value (the state when
    logging began) is not taken for a firing; a log whose values all change is not
    affected.

    Parameters
    ----------
    sensor : array_like of int
        Transducer of each value, in message order.
    t : array_like of float
        Stamp of each value (s).
    stale : array_like of bool
        :func:`stale_mask`.

    Returns
    -------
    numpy.ndarray of bool
        Values marked stale that are new firings.

    Examples
    --------
    Two transducers in every message, firing in turn every half second; transducer 1
    reads 2.0 twice running, so the message at t = 3.5 changes nothing:

    >>> sensor = np.array([0, 1] * 8)
    >>> t = np.repeat(np.arange(8) * 0.5, 2)
    >>> value = np.array([1.0, 5.0, 1.0, 1.5, 1.2, 1.5, 1.2, 1.8,
    ...                   1.4, 1.8, 1.4, 2.0, 1.6, 2.0, 1.6, 2.0])
    >>> stale = stale_mask(sensor, value_key(value))
    >>> refired_mask(sensor, t, stale).nonzero()[0].tolist()
    [15]
    """
    s = np.asarray(sensor)
    tt = np.asarray(t, dtype=np.float64)
    st = np.asarray(stale, dtype=bool)
    out = np.zeros(s.size, dtype=bool)
    starts = np.flatnonzero(np.r_[True, tt[1:] != tt[:-1]]) if s.size else np.zeros(0, int)
    ends = np.r_[starts[1:], s.size]
    quiet = [(a, b) for a, b in zip(starts, ends, strict=True) if b - a >= 2 and st[a:b].all()]
    if not quiet:
        return out
    # a transducer's first value is the state when logging began, not a firing then
    changed = {int(k): np.sort(tt[(s == k) & ~st])[1:] for k in np.unique(s)}
    fired = {k: v for k, v in changed.items() if v.size}
    gaps = [float(np.diff(v).min()) for v in fired.values() if v.size >= 2]
    cycle = min(gaps, default=0.0)
    if not cycle > 0:
        return out
    spacing = cycle / len(changed)  # the ring fires every transducer once per cycle
    last_credit: dict[int, float] = {}
    for a, b in quiet:
        now = float(tt[a])
        best, best_off = -1, PHASE_TOLERANCE * spacing
        for i in range(a, b):
            k = int(s[i])
            if k not in fired:
                continue
            before = fired[k][: np.searchsorted(fired[k], now)]
            last = max(before[-1] if before.size else -np.inf, last_credit.get(k, -np.inf))
            if not np.isfinite(last) or now - last < 0.5 * cycle:
                continue
            off = abs((now - last + 0.5 * cycle) % cycle - 0.5 * cycle)
            if off <= best_off:
                best, best_off = i, off
        if best >= 0:
            out[best] = True
            last_credit[int(s[best])] = now
    return out
