"""One line a person reads about a run: the metrics in their units.

>>> summary_line({"counts": {"readings_used": 10},
...               "metrics": {"e": 0.5, "f_c": 0.9, "E1_m": 0.0331, "t_cpu_s": 0.2}})
'10 used, e 0.500, f_c 0.900, E1 3.31 cm'
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
    if "E1_m" in m:
        parts.append(f"E1 {length_cm(m['E1_m'])}")
    if "precision_m" in m:
        parts.append(f"precision {length_cm(m['precision_m'])}")
    return ", ".join(parts)
