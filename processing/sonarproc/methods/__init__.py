"""Map-building methods for sonar, side by side (one base class, a small registry).

Every method turns a log's readings into a map on the same grid; the same fit and the
same metrics as ``sonarproc run`` follow (:class:`~sonarproc.methods.base.MapMethod`).

=================  ==================================================================
name               method
=================  ==================================================================
``morphological``  the paper: arc map + morphological ``--ops`` (``sonarproc run``)
``arc-vote``       the arc count map's crest (``--ops vote:auto,ridge``)
``line-of-sight``  one point per echo on the beam axis
``histogram``      Borenstein & Koren's histogram grid (VFH/HIMM certainty values)
``occupancy``      Elfes & Moravec's log-odds certainty grid, inverse sonar model
``directional-``   Barshan (2007): each arc votes for its cell of maximum count
``max``
``arc-median``     Choset et al. (2003): each arc votes for the median of its crossings
``triangulation``  Wijk & Christensen (2000): supported crossings of nearby readings
=================  ==================================================================

Examples
--------
>>> len(METHODS), sorted(METHODS)[:3]
(8, ['arc-median', 'arc-vote', 'directional-max'])
>>> make_method("histogram", threshold=6).options["threshold"]
6
"""

from __future__ import annotations

from sonarproc.errors import ParameterError
from sonarproc.methods.arc_selection import ArcMedian, DirectionalMaximum
from sonarproc.methods.base import Beams, MapMethod, MethodMap, MethodResult, OptionValue
from sonarproc.methods.line_of_sight import Histogram, LineOfSight
from sonarproc.methods.morphological import ArcVote, Morphological
from sonarproc.methods.occupancy import Occupancy
from sonarproc.methods.triangulation import Triangulation

__all__ = [
    "DEFAULT_METHODS",
    "METHODS",
    "Beams",
    "MapMethod",
    "MethodMap",
    "MethodResult",
    "OptionValue",
    "make_method",
    "parse_method_list",
    "parse_settings",
]

#: Registered methods by name.
METHODS: dict[str, type[MapMethod]] = {
    cls.name: cls
    for cls in (
        Morphological,
        ArcVote,
        LineOfSight,
        Histogram,
        Occupancy,
        DirectionalMaximum,
        ArcMedian,
        Triangulation,
    )
}
#: What ``sonarproc compare`` runs without ``--methods``.
DEFAULT_METHODS = (
    "morphological",
    "arc-vote",
    "directional-max",
    "arc-median",
    "triangulation",
    "line-of-sight",
    "histogram",
    "occupancy",
)


def make_method(name: str, **options: OptionValue) -> MapMethod:
    """An instance of the registered method ``name`` with ``options``.

    Raises
    ------
    ValueError
        Unknown method or option.
    """
    try:
        cls = METHODS[name]
    except KeyError:
        raise ParameterError(
            "method", f"must be one of {', '.join(sorted(METHODS))}, got {name!r}"
        ) from None
    return cls(**options)


def parse_method_list(text: str) -> list[str]:
    """Split ``"a,b,c"`` into known method names (in order, without repeats).

    Examples
    --------
    >>> parse_method_list("occupancy, line-of-sight,occupancy")
    ['occupancy', 'line-of-sight']
    """
    names = list(dict.fromkeys(p.strip() for p in text.split(",") if p.strip()))
    if not names:
        raise ParameterError("methods", "must name at least one method")
    for n in names:
        if n not in METHODS:
            raise ParameterError(
                "methods", f"must be one of {', '.join(sorted(METHODS))}, got {n!r}"
            )
    return names


def parse_settings(items: list[str]) -> dict[str, dict[str, str]]:
    """Parse ``["occupancy.select=ridge", ...]`` into ``{method: {option: value}}``.

    Examples
    --------
    >>> parse_settings(["histogram.threshold=6", "occupancy.p_occ=0.8"])
    {'histogram': {'threshold': '6'}, 'occupancy': {'p_occ': '0.8'}}
    """
    out: dict[str, dict[str, str]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        method, dot, option = key.strip().partition(".")
        if not (sep and dot and method and option):
            raise ParameterError("settings", f"must be METHOD.OPTION=VALUE, got {item!r}")
        if method not in METHODS:
            raise ParameterError("settings", f"name an unknown method {method!r}")
        out.setdefault(method, {})[option] = value.strip()
    return out
