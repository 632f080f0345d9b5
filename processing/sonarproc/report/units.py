"""How people read numbers: lengths in cm with their unit, 3 significant figures.

JSON stays SI with unit-suffixed keys (``E1_m``, ``t_cpu_s``); everything a person reads
(the terminal, the HTML report, figure labels) goes through these formatters, so a length
never shows as a bare float or in two units.

>>> length_cm(0.03298680091298159)
'3.30 cm'
>>> length_cm(None)
'—'
>>> length_cm(1.31e8)
'unbounded'
>>> number(0.86123)
'0.861'
>>> seconds(0.2567)
'0.257 s'
"""

from __future__ import annotations

import math
from typing import Any

__all__ = [
    "MAX_LENGTH_M",
    "MISSING",
    "UNBOUNDED",
    "length_cm",
    "metric",
    "number",
    "seconds",
    "sig3",
]

#: Shown where a value is absent (no truth, a failed fit).
MISSING = "—"
#: Shown instead of a length that is not one: infinite, NaN, or beyond :data:`MAX_LENGTH_M`.
UNBOUNDED = "unbounded"
#: The longest length (m) shown as a number. Sonar transducers hear a few metres (the
#: Polaroid 6500 at most 10.7 m) and a log maps at most a building, so no distance, error
#: or residual of a map reaches a kilometre; a larger value is a fit that diverges (a
#: polynomial far outside its points), and printing "1.31e+10 cm" would read as a measure.
MAX_LENGTH_M = 1000.0


def sig3(value: float) -> str:
    """``value`` with 3 significant figures, keeping trailing zeros (``3.30``, ``0.0412``).

    Beyond 100 000 (a fit gone wild) or below 0.001, in exponent form: ``4.24e+08``.

    >>> sig3(424073262.0), sig3(0.000123), sig3(1234.5)
    ('4.24e+08', '1.23e-04', '1234')
    """
    if value == 0 or not math.isfinite(value):
        return f"{value:g}"
    if not 1e-3 <= abs(value) < 1e5:
        return f"{value:.2e}"
    digits = max(0, 2 - math.floor(math.log10(abs(value))))
    return f"{value:.{digits}f}"


def length_cm(metres: float | None) -> str:
    """A length given in metres, shown in cm: ``'3.30 cm'``.

    ``None`` is :data:`MISSING`; a non-finite length, or one beyond :data:`MAX_LENGTH_M`,
    is :data:`UNBOUNDED`.

    >>> length_cm(float("inf")), length_cm(-2e3), length_cm(12.5)
    ('unbounded', 'unbounded', '1250 cm')
    """
    if metres is None:
        return MISSING
    if not math.isfinite(metres) or abs(metres) > MAX_LENGTH_M:
        return UNBOUNDED
    return f"{sig3(100.0 * metres)} cm"


def seconds(value: float | None) -> str:
    """A duration in seconds: ``'0.257 s'``."""
    return MISSING if value is None else f"{sig3(value)} s"


def number(value: float | None) -> str:
    """A dimensionless measure (e, f_c, E2) with 3 significant figures."""
    return MISSING if value is None else sig3(float(value))


def metric(key: str, value: Any) -> str:
    """Format a ``report.json`` metric by its key's unit suffix (``_m``, ``_s``, none)."""
    if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return MISSING if value is None else str(value)
    if key.endswith("_m"):
        return length_cm(float(value))
    if key.endswith("_s"):
        return seconds(float(value))
    if isinstance(value, int):
        return str(value)
    return number(float(value))
