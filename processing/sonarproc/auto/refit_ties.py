"""Which echo refits the held-out readings cannot tell apart, and which of them is taken.

:func:`sonarproc.auto.echo_refit.choose_refit` scores every refit setting
(:class:`~sonarproc.auto.refit_rounds.RefitSetting`: smoothing splines and polynomials) by
its held-out range residual; this module says which settings are tied with the best.

Two smoothing lengths are tied within :data:`SPLINE_TIE_SE` paired standard error over
firings (:func:`~sonarproc.auto.score.clustered_paired_se`): the folds hold out whole
firings, and on a log where every pair listens one firing gives dozens of held-out
readings that share its pose and its stretch of surface, so counted one by one they
separate lengths whose residuals differ by hundredths of a millimetre. A smoothing length
next to the best one is tied with it also when neither is better on both counts
(:func:`undominated`): the best predicts more of the held-out readings (a rougher curve
has the normals that give specular points at bumps; so has noise), the neighbour predicts
the readings both predict better. A polynomial and a spline, or two polynomials, are tied
within :data:`TIE_SE` paired standard errors over readings.

Among the tied settings a polynomial is preferred over the splines if it agrees with a
reference refit (:func:`references`) within a tolerance on every column where readings
echo (:func:`simplest_agreeing`): where the readings see the surface the two are then the
same curve.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.auto.refit_rounds import Profile, RefitSetting, Span
from sonarproc.auto.score import clustered_paired_se, paired_se, robust_residual

__all__ = [
    "NEIGHBOUR_TIE", "SPLINE_TIE_SE", "TIE_SE",
    "references", "simplest_agreeing", "tie_reasons", "tied_settings", "undominated",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]

#: Refits whose held-out residuals are within this many paired standard errors (over
#: readings) of the lowest are tied, unless both are splines (:func:`tied_settings`); a
#: refit within this many of the chosen candidate's residual, or below it, is applied.
TIE_SE = 2.0
#: Two smoothing lengths are tied within this many paired standard errors over firings
#: (the one-standard-error rule).
SPLINE_TIE_SE = 1.0
#: How :func:`tie_reasons` starts the reason of a neighbouring length neither of which is
#: better on both counts (:func:`undominated`).
NEIGHBOUR_TIE = "next to the best; "


def references(tied: tuple[RefitSetting, ...], best: RefitSetting) -> list[RefitSetting]:
    """The refits a tied polynomial is compared with, in turn (:func:`simplest_agreeing`).

    First the tied spline of the shortest smoothing length (the one that follows the echo
    points most closely); then, if the best refit is a polynomial, that polynomial: a
    polynomial that predicts better than every spline is kept even if no spline agrees
    with it (the splines' average is for when a spline is best).

    Examples
    --------
    >>> s1, s4 = RefitSetting("spline", 0.1), RefitSetting("spline", 0.4)
    >>> p6 = RefitSetting("poly", 6)
    >>> [k.short for k in references((p6, s1, s4), s4)]
    ['spline L=0.1 m']
    >>> [k.short for k in references((p6, s4), p6)]
    ['spline L=0.4 m', 'poly m=6']
    """
    splines = [k for k in tied if k.family == "spline"]
    out = [min(splines)] if splines else []
    return out + ([best] if best.family == "poly" else [])


def simplest_agreeing(
    tied: tuple[RefitSetting, ...],
    reference: RefitSetting,
    fits: dict[RefitSetting, Profile],
    echo_x: dict[RefitSetting, FloatArray],
    spans: dict[RefitSetting, Span],
    tolerance: float,
) -> tuple[RefitSetting, float] | None:
    """The lowest-order tied polynomial that agrees with the ``reference`` refit.

    A polynomial agrees if it is within ``tolerance`` (m) of the reference at every
    column where the reference's readings echo (``echo_x``), between the polynomial's
    own outermost echo points (``spans``; beyond them it is not reported), and there is
    at least one such column. A polynomial that misses a feature the readings see loses
    that feature's echo points, but not the reference's.

    Returns
    -------
    (RefitSetting, float) or None
        The polynomial and its largest difference (m) from the reference; None if no
        tied polynomial agrees.

    Examples
    --------
    A quadratic's samples: the spline through them and the quadratic agree, a line does
    not.

    >>> from sonarproc.fit import fit_polynomial, fit_spline
    >>> x = np.linspace(0.0, 4.0, 41)
    >>> y = 2.0 + 0.05 * (x - 2.0) ** 2
    >>> s, p2, p1 = RefitSetting("spline", 0.1), RefitSetting("poly", 2), RefitSetting("poly", 1)
    >>> fits = {s: fit_spline(x, y, np.ones(41), lam=1e-6),
    ...         p2: fit_polynomial(x, y, np.ones(41), order=2),
    ...         p1: fit_polynomial(x, y, np.ones(41), order=1)}
    >>> spans = dict.fromkeys(fits, (0.0, 4.0))
    >>> simplest_agreeing((p1, p2, s), s, fits, {s: x}, spans, 0.01)[0].short
    'poly m=2'
    >>> simplest_agreeing((p1, s), s, fits, {s: x}, spans, 0.01) is None
    True
    """
    xs = echo_x[reference]
    for k in sorted(k for k in tied if k.family == "poly"):
        lo, hi = spans[k]
        at = xs[(xs >= lo) & (xs <= hi)]
        if not at.size:
            continue  # no column to compare on: no evidence that they agree
        gap = float(np.max(np.abs(fits[k](at) - fits[reference](at))))
        if gap <= tolerance:
            return k, gap
    return None


def undominated(best: FloatArray, other: FloatArray, cap: float) -> bool:
    """Whether ``other``'s held-out losses lose to ``best``'s only by predicting fewer readings.

    True when ``best`` predicts more of the readings (a loss below ``cap``: the curve has
    a specular point for the reading, and it is not off by the cap) and ``other``
    predicts the readings both predict better (:func:`robust_residual`): neither is
    better on both counts.

    Examples
    --------
    The best predicts two readings more; on the other six the other curve is closer.

    >>> best = np.array([0.02, 0.02, 0.02, 0.02, 0.02, 0.02, 0.03, 0.03])
    >>> other = np.array([0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.1, 0.1])
    >>> undominated(best, other, 0.1), undominated(best, best + 0.01, 0.1)
    (True, False)
    """
    return _undominated_why(best, other, cap) is not None


def _undominated_why(best: FloatArray, other: FloatArray, cap: float) -> str | None:
    """:func:`undominated`'s counts in words, or None when ``other`` is dominated."""
    hit_best, hit_other = best < cap, other < cap
    both = hit_best & hit_other
    if not both.any() or hit_best.sum() <= hit_other.sum():
        return None
    theirs, mine = robust_residual(other[both]), robust_residual(best[both])
    if theirs >= mine:
        return None
    return (
        f"better on the {int(both.sum())} readings both predict ({100 * theirs:.3g} cm "
        f"against {100 * mine:.3g} cm), the best predicts "
        f"{int(hit_best.sum() - hit_other.sum())} more"
    )


def tied_settings(
    residuals: dict[RefitSetting, float],
    losses: dict[RefitSetting, FloatArray],
    firings: npt.NDArray[np.intp],
    cap: float | None = None,
) -> tuple[RefitSetting, ...]:
    """The settings the held-out readings cannot tell apart from the best (module notes).

    Two splines are tied when the difference of their residuals is within
    :data:`SPLINE_TIE_SE` paired standard errors over firings (``firings``: each held-out
    loss's firing); any other pair within :data:`TIE_SE` paired standard errors over
    readings. With ``cap`` (the losses' cap, m), the smoothing lengths next to the best
    spline's are tied with it also when neither is better on both counts
    (:func:`undominated`).

    Examples
    --------
    Twenty firings of twenty readings each. The 0.2 m spline and the order-6
    polynomial lose the same as the 0.1 m spline on every reading, plus 1 mm on every
    reading of half of the firings, 1 mm less on the others, and 0.2 mm on all: about two
    standard errors over readings, half of one over firings.

    >>> rng = np.random.default_rng(0)
    >>> base = 0.002 + rng.random(400) * 0.01
    >>> firings = np.arange(400) // 20
    >>> s1, s2 = RefitSetting("spline", 0.1), RefitSetting("spline", 0.2)
    >>> p6 = RefitSetting("poly", 6)
    >>> worse = base + np.where(firings % 2 == 0, 0.001, -0.001) + 0.0002
    >>> losses = {s1: base, s2: worse, p6: worse}
    >>> residuals = {k: robust_residual(v) for k, v in losses.items()}
    >>> [k.short for k in tied_settings(residuals, losses, firings)]
    ['spline L=0.1 m', 'spline L=0.2 m']
    """
    return tuple(sorted(tie_reasons(residuals, losses, firings, cap)))


def tie_reasons(
    residuals: dict[RefitSetting, float],
    losses: dict[RefitSetting, FloatArray],
    firings: npt.NDArray[np.intp],
    cap: float | None = None,
) -> dict[RefitSetting, str]:
    """Why each setting of :func:`tied_settings` is tied with the best, in a few words.

    Examples
    --------
    Twenty firings of eight readings; the 0.2 m spline misses three of each firing.

    >>> s1, s2 = RefitSetting("spline", 0.1), RefitSetting("spline", 0.2)
    >>> firing = np.repeat(np.arange(20), 8)
    >>> losses = {s1: np.full(160, 0.02), s2: np.tile(np.r_[np.full(5, 0.015), [0.1] * 3], 20)}
    >>> residuals = {k: robust_residual(v) for k, v in losses.items()}
    >>> why = tie_reasons(residuals, losses, firing, cap=0.1)
    >>> why[s1]
    'the best'
    >>> print(why[s2])  # doctest: +NORMALIZE_WHITESPACE
    next to the best; better on the 100 readings both predict (1.5 cm against 2 cm),
    the best predicts 60 more
    """
    best = min(residuals, key=lambda k: residuals[k])
    splines = sorted(k for k in residuals if k.family == "spline")
    neighbours: set[RefitSetting] = set()
    if best.family == "spline":
        i = splines.index(best)
        neighbours = set(splines[max(i - 1, 0) : i + 2]) - {best}
    out = {best: "the best"}
    for k in sorted(residuals):
        if k == best:
            continue
        gap = residuals[k] - residuals[best]
        if k.family == "spline" and best.family == "spline":
            se = float(np.nan_to_num(clustered_paired_se(losses[best], losses[k], firings)))
            if gap <= SPLINE_TIE_SE * se:
                out[k] = f"within {SPLINE_TIE_SE:g} paired standard error over firings"
            elif k in neighbours and cap is not None:
                why = _undominated_why(losses[best], losses[k], cap)
                if why is not None:
                    out[k] = NEIGHBOUR_TIE + why
        elif gap <= TIE_SE * float(np.nan_to_num(paired_se(losses[best], losses[k]))):
            out[k] = f"within {TIE_SE:g} paired standard errors over readings"
    return out
