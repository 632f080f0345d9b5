"""Explain unaccounted firings from what a failed soak left: the log, trace and fault list.

A soak that finds firings neither logged nor inside a logged ``gap`` must say enough to be
diagnosed from its output alone (a CI run's work directory is gone by the time anyone
looks). :func:`explain_unaccounted` groups the unaccounted firings into runs (firings less
than one firing cycle apart) and, for the first runs, prints the logged readings on
either side, the log's events nearby, what the emulator heard from sonard meanwhile (its
trace) and the faults it injected then. Times are seconds after the log's first reading.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import numpy as np

from sonard.soak.accounting import FiringClasses, clock_offset
from sonarlog import SonarLog
from sonarlog.schema import EVENT_DTYPE

__all__ = ["explain_unaccounted", "lost_runs"]

#: events and faults this far (s) either side of a run of lost firings are shown
CONTEXT_S = 2.0
#: the emulator's trace records this far (s) either side of a run are shown
TRACE_CONTEXT_S = 0.5


def lost_runs(t: np.ndarray, gap: float) -> list[tuple[int, int]]:
    """``[start, stop)`` index ranges of sorted times split where they are ``> gap`` apart.

    Examples
    --------
    >>> lost_runs(np.array([1.0, 1.04, 1.08, 3.0, 3.04]), 0.2)
    [(0, 3), (3, 5)]
    """
    if not len(t):
        return []
    cuts = np.flatnonzero(np.diff(t) > gap) + 1
    bounds = [0, *cuts.tolist(), len(t)]
    return list(itertools.pairwise(bounds))


def _trace_records(trace: Path, lo: float, hi: float) -> list[dict[str, Any]]:
    """The trace's non-firing records with robot time in ``[lo, hi]``."""
    out = []
    with open(trace, encoding="utf-8") as fh:
        for line in fh:
            if '"firing"' in line:
                continue
            try:
                rec = json.loads(line)
            except ValueError:
                continue  # a line cut by the emulator's end
            if lo <= float(rec.get("t", -np.inf)) <= hi:
                out.append(rec)
    return out


def _faults(faults: Path, lo: float, hi: float) -> list[dict[str, Any]]:
    """The injected faults (UNIX wall times) overlapping ``[lo, hi]``."""
    out = []
    for line in faults.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        if rec["end"] >= lo and rec["start"] <= hi:
            out.append(rec)
    return out


def _readings_line(r: np.ndarray, base: float) -> str:
    return ", ".join(f"+{t - base:.3f} s{int(s)}" for t, s in zip(r["t"], r["rx"], strict=True))


def explain_unaccounted(
    classes: FiringClasses,
    log: SonarLog,
    *,
    cycle: float,
    trace: Path | None = None,
    faults: Path | None = None,
    max_runs: int = 2,
) -> list[str]:
    """Lines (about 10 per run) that describe the first runs of unaccounted firings.

    Parameters
    ----------
    classes : FiringClasses
        From :func:`sonard.soak.accounting.classify_firings` on ``log``.
    log : SonarLog
        The log.
    cycle : float
        One firing cycle (s): lost firings closer than this belong to one run.
    trace, faults : Path, optional
        The emulator's trace (JSON lines, robot clock) and its fault list (UNIX times).
    max_runs : int
        How many runs to describe.

    Returns
    -------
    list of str
        Empty when nothing is unaccounted.
    """
    lost = classes.lost
    t, sonar = classes.t[lost], classes.sonar[lost]
    if not len(t):
        return []
    r = log.readings
    base = float(r["t"].min())
    offset = clock_offset(log)
    runs = lost_runs(t, 1.5 * cycle)
    lines = [
        f"unaccounted: {len(t)} firings in {len(runs)} run(s); times in s after the first "
        f"reading (UNIX {base:.3f}; robot clock 0 = UNIX {offset:.3f})"
    ]
    ev = log.events if log.events is not None else np.zeros(0, EVENT_DTYPE)
    for k, (i, j) in enumerate(runs[:max_runs]):
        a, b = float(t[i]), float(t[j - 1])
        sonars = sorted({int(s) for s in sonar[i:j]})
        lines.append(
            f"run {k + 1}: {j - i} firings of sonars {sonars}, +{a - base:.3f} .. +{b - base:.3f}"
            f" (robot {a - offset:.3f} .. {b - offset:.3f})"
        )
        before = r[r["t"] < a - 1e-4][-3:]
        after = r[r["t"] > b + 1e-4][:3]
        lines.append(f"  logged before: {_readings_line(before, base) or 'none'}")
        lines.append(f"  logged after:  {_readings_line(after, base) or 'none'}")
        near = ev[(ev["t"] >= a - CONTEXT_S) & (ev["t"] <= b + CONTEXT_S)]
        for e in near[:8]:
            kind, detail = (bytes(e[k]).decode(errors="replace") for k in ("kind", "detail"))
            lines.append(f"  event +{float(e['t']) - base:.3f} {kind}: {detail[:70]}")
        if len(near) > 8:
            lines.append(f"  ... {len(near) - 8} more events")
        if not len(near):
            lines.append(f"  no event within {CONTEXT_S:g} s")
        if trace is not None and trace.exists():
            lo, hi = a - offset - TRACE_CONTEXT_S, b - offset + TRACE_CONTEXT_S
            recs = _trace_records(trace, lo, hi)
            heard = [
                f"+{float(x['t']) + offset - base:.3f} {x.get('cmd', x.get('type', '?'))}"
                for x in recs
            ]
            lines.append(f"  emulator heard (±{TRACE_CONTEXT_S:g} s): {len(heard)} records")
            for n in range(0, min(len(heard), 24), 8):
                lines.append("    " + ", ".join(heard[n : n + 8]))
        if faults is not None and faults.exists():
            for f in _faults(faults, a - CONTEXT_S, b + CONTEXT_S):
                lines.append(
                    f"  fault {f['kind']}: +{f['start'] - base:.3f} .. +{f['end'] - base:.3f}"
                    " (emulator wall clock)"
                )
    if len(runs) > max_runs:
        lines.append(f"... {len(runs) - max_runs} more run(s)")
    return lines
