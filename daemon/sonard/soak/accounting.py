"""The soak's checks: firings against the log, and resource slopes.

Every firing in the emulator's trace must be in the log (same sonar, same firing time to
the protocol's millisecond) or fall inside an outage the log records: a ``gap`` event
(good replies too far apart to see every firing, detail ``until T``). Firings before the
first and after the last reading are outside the run and not counted.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from sonarlog import SonarLog

__all__ = [
    "Accounting",
    "FiringClasses",
    "account_firings",
    "classify_firings",
    "clock_offset",
    "load_firings",
    "outage_windows",
    "slope_per_hour",
]

#: firing times match to the protocol's 1 ms clock, plus float slack (s)
MATCH_TOL_S = 0.0015
_UNTIL = re.compile(rb"until ([0-9.]+)")
_CLOCK = re.compile(rb"UNIX time ([0-9.]+)")


@dataclass(frozen=True)
class Accounting:
    """How the emulator's firings are accounted for.

    Attributes
    ----------
    firings : int
        Firings between the first and the last reading of the log.
    logged : int
        Those with a matching reading.
    in_outage : int
        Those without one, inside a logged outage.
    unaccounted : int
        Neither: readings lost silently. Must be 0.
    extra_readings : int
        Readings with no firing (must be 0 too).
    examples : list of (sonar, UNIX time)
        Up to five unaccounted firings, to look into.
    """

    firings: int
    logged: int
    in_outage: int
    unaccounted: int
    extra_readings: int
    examples: list[tuple[int, float]] = field(default_factory=list)


def load_firings(trace: Path) -> tuple[np.ndarray, np.ndarray]:
    """(robot clock s, sonar id) of every firing in an emulator trace (JSON lines)."""
    t: list[float] = []
    sid: list[int] = []
    with open(trace, encoding="utf-8") as fh:
        for line in fh:
            if '"firing"' in line:
                rec = json.loads(line)
                t.append(rec["t"])
                sid.append(rec["sonar"])
    return np.asarray(t, dtype=np.float64), np.asarray(sid, dtype=np.int64)


def clock_offset(log: SonarLog) -> float:
    """UNIX time of robot clock 0 from the log's first ``clock`` event."""
    if log.events is not None:
        for e in log.events[log.events["kind"] == b"clock"]:
            m = _CLOCK.search(bytes(e["detail"]))
            if m:
                return float(m.group(1))
    raise ValueError(f"{log.path}: no clock event")


def outage_windows(log: SonarLog, interval: float) -> np.ndarray:
    """``(N, 2)`` UNIX [start, end] of every ``gap`` event, widened by one firing interval.

    A firing whose echo was still out at the last good reply fired up to one interval
    before it.
    """
    if log.events is None:
        return np.zeros((0, 2))
    rows = []
    for e in log.events[log.events["kind"] == b"gap"]:
        m = _UNTIL.search(bytes(e["detail"]))
        if m:
            rows.append((float(e["t"]) - interval - MATCH_TOL_S, float(m.group(1)) + MATCH_TOL_S))
    return np.asarray(rows, dtype=np.float64).reshape(-1, 2)


def _inside(t: np.ndarray, windows: np.ndarray) -> np.ndarray:
    if not len(windows):
        return np.zeros(len(t), dtype=bool)
    w = windows[np.argsort(windows[:, 0])]
    # running maximum of the ends: a window swallowed by an earlier, longer one still counts
    ends = np.maximum.accumulate(w[:, 1])
    k = np.searchsorted(w[:, 0], t, side="right") - 1
    return (k >= 0) & (t <= ends[np.maximum(k, 0)])


def _matched(keys: np.ndarray, sorted_keys: np.ndarray, tol: float) -> np.ndarray:
    """Whether each key has a sorted key within ``tol``."""
    if not len(sorted_keys):
        return np.zeros(len(keys), dtype=bool)
    pos = np.searchsorted(sorted_keys, keys)
    lo = sorted_keys[np.clip(pos - 1, 0, len(sorted_keys) - 1)]
    hi = sorted_keys[np.clip(pos, 0, len(sorted_keys) - 1)]
    return (np.abs(keys - lo) <= tol) | (np.abs(keys - hi) <= tol)


class FiringClasses(NamedTuple):
    """The firings inside a log's span, each classified (arrays of one length, time order).

    Attributes
    ----------
    t : ndarray
        Firing time, UNIX seconds (robot clock + the log's clock offset).
    sonar : ndarray
        Sonar id.
    logged : ndarray of bool
        A reading of the same sonar within :data:`MATCH_TOL_S`.
    in_outage : ndarray of bool
        Not logged, inside a logged ``gap``.
    extra_readings : int
        Readings of the log with no firing.
    """

    t: np.ndarray
    sonar: np.ndarray
    logged: np.ndarray
    in_outage: np.ndarray
    extra_readings: int

    @property
    def lost(self) -> np.ndarray:
        """Neither logged nor inside a logged outage."""
        return ~self.logged & ~self.in_outage


def classify_firings(
    fire_t: np.ndarray,
    fire_sonar: np.ndarray,
    log: SonarLog,
    *,
    interval: float,
) -> FiringClasses:
    """Match the emulator's firings (robot clock) against a log's readings and gaps.

    Parameters
    ----------
    fire_t, fire_sonar : ndarray
        From :func:`load_firings`.
    log : SonarLog
        The log sonard wrote while the trace was taken (with at least one reading).
    interval : float
        The plan's firing interval (s).

    Returns
    -------
    FiringClasses
    """
    r = log.readings
    offset = clock_offset(log)
    order = np.argsort(fire_t, kind="stable")
    t = offset + fire_t[order]
    span = (t >= r["t"].min() - MATCH_TOL_S) & (t <= r["t"].max() + MATCH_TOL_S)
    t, sonar = t[span], fire_sonar[order][span]
    # one sorted axis for (sonar, time): sonars 0..15 far apart, times relative to the run
    base = float(r["t"].min())
    stride = 1e7
    read_keys = np.sort(r["rx"].astype(np.float64) * stride + (r["t"] - base))
    fire_keys = sonar.astype(np.float64) * stride + (t - base)
    logged = _matched(fire_keys, read_keys, MATCH_TOL_S)
    outage = ~logged & _inside(t, outage_windows(log, interval))
    extra = ~_matched(read_keys, np.sort(fire_keys), MATCH_TOL_S)
    return FiringClasses(t, sonar, logged, outage, int(extra.sum()))


def account_firings(
    fire_t: np.ndarray,
    fire_sonar: np.ndarray,
    log: SonarLog,
    *,
    interval: float,
) -> Accounting:
    """Count the emulator's firings (robot clock) logged, in an outage, or lost.

    Parameters
    ----------
    fire_t, fire_sonar : ndarray
        From :func:`load_firings`.
    log : SonarLog
        The log sonard wrote while the trace was taken.
    interval : float
        The plan's firing interval (s).

    Returns
    -------
    Accounting
    """
    if not len(log.readings):
        return Accounting(0, 0, 0, 0, 0)
    c = classify_firings(fire_t, fire_sonar, log, interval=interval)
    lost = c.lost
    examples = [(int(s), float(x)) for s, x in zip(c.sonar[lost][:5], c.t[lost][:5], strict=True)]
    return Accounting(
        firings=len(c.t),
        logged=int(c.logged.sum()),
        in_outage=int(c.in_outage.sum()),
        unaccounted=int(lost.sum()),
        extra_readings=c.extra_readings,
        examples=examples,
    )


def slope_per_hour(t: np.ndarray, values: np.ndarray) -> float:
    """Least-squares slope of ``values`` against ``t`` (s), per hour; 0 for < 3 samples.

    Examples
    --------
    >>> round(slope_per_hour(np.array([0.0, 1800.0, 3600.0]), np.array([5.0, 6.0, 7.0])), 6)
    2.0
    """
    if len(t) < 3 or np.ptp(t) == 0:
        return 0.0
    return float(np.polyfit(t, values, 1)[0] * 3600.0)
