"""The small, stated set of configurations ``--auto`` chooses from.

A candidate is a map-building method (:mod:`sonarproc.methods`) with its options and a
fit family; within its family, the fit's complexity (the polynomial's order, the
spline's smoothing length) is chosen by the same held-out criterion. Every candidate
fits a profile ``y(x)`` to its map's column means (the paper's binned fit) and is judged
on the columns between its first and last point (``span="points"``):

===================  ===============================  =====================================
candidate            map                              fit family (settings tried)
===================  ===============================  =====================================
``arc-vote/poly``    count vote + crest per column    polynomial, order 2, 4, 6, 9, 12, 15
``arc-vote/spline``  count vote + crest per column    spline, smoothing length 0.1-1.6 m
``dirmax/poly``      directional maximum (Barshan)    polynomial
``dirmax/spline``    directional maximum (Barshan)    spline
``median/spline``    arc-transversal median (Choset)  spline
``triang/spline``    triangulation (Wijk)             spline
``los/spline``       line of sight                    spline
``paper/poly``       the paper's ``thinning:3``       polynomial
``surfaces``         the paper's ``thinning:3``       ``fit = "auto"``: several surfaces (a
                                                      line, an arc or a spline each)
===================  ===============================  =====================================

``surfaces`` is the fit of scenes that are not one profile ``y(x)`` (a room, a corridor,
a pillar): :func:`sonarproc.pipeline.surfacefit.choose_fit` on the map; where it finds
one function of ``x``, on the map or among the surfaces refitted through the echo points,
the candidate stands aside (the ``y(x)`` candidates cover it).

A spline's smoothing length ``L`` sets its roughness penalty so that waves shorter than
about ``L`` are smoothed away: ``lam = (mean column count / cell) * (L / 2 pi)**4``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from sonarproc.methods import MapMethod, OptionValue, make_method
from sonarproc.params import RunParams

__all__ = ["CANDIDATES", "ORDERS", "SMOOTHING_LENGTHS", "Candidate", "spline_lambda"]

#: Polynomial orders a ``poly`` candidate tries.
ORDERS = (2, 4, 6, 9, 12, 15)
#: Smoothing lengths (m) a ``spline`` candidate tries.
SMOOTHING_LENGTHS = (0.1, 0.2, 0.4, 0.8, 1.6)


def spline_lambda(length: float, mean_count: float, cell: float) -> float:
    """Roughness penalty that smooths away waves shorter than about ``length`` (m).

    Examples
    --------
    >>> round(spline_lambda(2 * math.pi, 1.0, 0.01), 6)
    100.0
    """
    return mean_count / cell * (length / (2 * math.pi)) ** 4


@dataclass(frozen=True)
class Candidate:
    """One configuration: a method with its options, and a fit family."""

    name: str
    method: str
    family: str
    options: dict[str, OptionValue] = field(default_factory=dict)

    def make(self) -> MapMethod:
        """The method instance."""
        return make_method(self.method, **self.options)

    @property
    def settings(self) -> tuple[float, ...]:
        """The complexities tried: orders, or smoothing lengths (m)."""
        if self.family == "surfaces":
            return (0.0,)
        return tuple(float(o) for o in ORDERS) if self.family == "poly" else SMOOTHING_LENGTHS

    def params(self, base: RunParams, setting: float, *, lam: float | None = None) -> RunParams:
        """``base`` with this candidate's fit at ``setting``, judged on the columns with points.

        ``lam``: the spline's roughness penalty (see :func:`spline_lambda`).
        """
        if self.family == "surfaces":
            return replace(base, fit="auto", auto_order=False, robust="none", span="points")
        fit = "poly" if self.family == "poly" else "spline"
        return replace(
            base,
            fit=fit,  # type: ignore[arg-type]
            auto_order=False,
            robust="none",
            order=int(setting) if fit == "poly" else None,
            smooth=lam if fit == "spline" else None,
            span="points",
        )

    def describe(self, setting: float | None = None) -> dict[str, object]:
        """JSON-ready description: method, options, fit (at ``setting``)."""
        if self.family == "surfaces":
            return {
                "method": self.method, "options": dict(self.options),
                "fit": "surfaces: a line, an arc or a spline each", "fit_short": "surfaces",
            }  # fmt: skip
        if self.family == "poly":
            fit = "polynomial" + ("" if setting is None else f", order {int(setting)}")
        else:
            fit = "smoothing spline" + (
                "" if setting is None else f", smoothing length {setting:g} m"
            )
        short = (
            self.family
            if setting is None
            else (f"poly m={int(setting)}" if self.family == "poly" else f"spline L={setting:g} m")
        )
        return {
            "method": self.method, "options": dict(self.options), "fit": fit, "fit_short": short,
        }  # fmt: skip


#: What ``--auto`` tries, in order of preference on a tie.
CANDIDATES: tuple[Candidate, ...] = (
    Candidate("arc-vote/poly", "arc-vote", "poly"),
    Candidate("arc-vote/spline", "arc-vote", "spline"),
    Candidate("dirmax/poly", "directional-max", "poly"),
    Candidate("dirmax/spline", "directional-max", "spline"),
    Candidate("median/spline", "arc-median", "spline"),
    Candidate("triang/spline", "triangulation", "spline"),
    Candidate("los/spline", "line-of-sight", "spline"),
    Candidate("paper/poly", "morphological", "poly", {"ops": "thinning:3"}),
    Candidate("surfaces", "morphological", "surfaces", {"ops": "thinning:3"}),
)
