"""One line a person reads about a run: the metrics in their units.

>>> summary_line({"counts": {"readings_used": 10},
...               "metrics": {"e": 0.5, "f_c": 0.9, "E1_m": 0.0331, "t_cpu_s": 0.2}})
'10 used, e 0.500, f_c 0.900, E1 3.31 cm'
>>> summary_line({"counts": {"readings_used": 9}, "fit": {"kind": "surfaces", "surfaces": 4},
...               "metrics": {"e": None, "f_c": 0.9, "precision_m": 0.006, "completeness": 0.95}})
'9 used, e —, f_c 0.900, 4 surfaces, precision 0.600 cm, completeness 0.950'
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sonarproc.report.units import length_cm, number

__all__ = ["summary_line"]


def summary_line(doc: Mapping[str, Any]) -> str:
    """``report.json``'s counts and metrics as one human line (lengths in cm)."""
    m = doc["metrics"]
    parts = [f"{doc['counts']['readings_used']} used", f"e {number(m.get('e'))}"]
    parts.append(f"f_c {number(m.get('f_c'))}")
    fit = doc.get("fit") or {}
    if fit.get("kind") == "surfaces" and "surfaces" in fit:
        parts.append(f"{fit['surfaces']} surfaces")
    if "E1_m" in m:
        parts.append(f"E1 {length_cm(m['E1_m'])}")
    if "precision_m" in m:
        parts.append(f"precision {length_cm(m['precision_m'])}")
    if "completeness" in m:
        parts.append(f"completeness {number(m['completeness'])}")
    return ", ".join(parts)
