"""``--auto``'s last step: the chosen profile refitted through the readings' echo points.

Every map method places the surface from the arcs' overlaps, with its own bias; a
reading's range says exactly how far the surface is at its specular point.
:mod:`sonarproc.auto.refit_rounds` finds each reading's echo point near the chosen
profile and fits a curve through them (:func:`refit_profile`). Which curve, and whether
it replaces the chosen candidate's fit, is decided here by the criterion of ``--auto``
itself (:func:`choose_refit`): each setting's fit to the echo points of the training
folds predicts the held-out readings, and the lowest trimmed mean range residual wins;
the settings close to it cannot be told apart by the readings (:func:`tied_settings`).
The refit replaces the chosen fit unless its residual is above the chosen candidate's
own by more than :data:`TIE_SE` paired standard errors.

Which settings the held-out readings cannot tell apart from the best, and which of
the tied ones is taken, is :mod:`sonarproc.auto.refit_ties`'s: the lowest-order tied
polynomial that agrees with the most flexible tied spline wherever readings echo (a
polynomial that predicts better than every spline is kept even when no tied spline agrees
with it), failing one the tied splines' refits averaged. A tied polynomial carries the
curvature on either side through a stretch that echoes nothing (a flank facing away from
the sensors), where a spline draws the straightest curve; one that misses a local feature
the readings do see (a dent, a hump) disagrees there and is not taken.

The rounds' tolerances follow the range noise, estimated about the starting profile.
An estimate above :data:`NOISE_MAX` says that the profile misses most readings (a room's
other walls), or that the start is far off on a very noisy log; the noise is then
estimated again about the best refit, and if that is believable the refits are made
again with its tolerances.

The refitted profile is reported only between its outermost echo points
(:attr:`RefitChoice.echo_span`; :mod:`sonarproc.auto.select`): beyond them the map's
bias carries it, centimetres to a decimetre off at a wave's ends.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.auto.holdout import (
    Split,
    curve_path,
    firing_index,
    heldout_splits,
    hull_excess,
    range_loss,
    subset_beams,
)
from sonarproc.auto.hull import HULL_WINDOW_CELLS, sensor_side
from sonarproc.auto.refit_rounds import (
    END_GAP_M,
    END_SHARE,
    HULL_NOISE_WIDTH,
    NOISE_MAX,
    NOISE_READINGS,
    NOISE_WIDTHS,
    REFIT_SETTINGS,
    ROUNDS_M,
    Profile,
    RefitSetting,
    Span,
    agreement_tolerance,
    believable_noise,
    echo_points,
    fit_points,
    fitted_points,
    hull_tolerance,
    main_body,
    range_noise,
    refit_profile,
    sample_curve,
    tolerances,
)
from sonarproc.auto.refit_ties import (
    NEIGHBOUR_TIE,
    SPLINE_TIE_SE,
    TIE_SE,
    references,
    simplest_agreeing,
    tie_reasons,
    tied_settings,
    undominated,
)
from sonarproc.auto.score import paired_se, robust_residual
from sonarproc.fit import Fit, PolyFit, SplineFit
from sonarproc.grid import Grid
from sonarproc.metrics import Bins
from sonarproc.pipeline.selection import Beams

# the rounds' and the ties' names are re-exported: this module is where ``--auto``
# finds the refit
__all__ = [
    "END_GAP_M", "END_SHARE", "HULL_NOISE_WIDTH", "MAX_PAIRS", "MIN_ECHO_POINTS",
    "NEIGHBOUR_TIE", "NOISE_MAX", "NOISE_READINGS", "NOISE_WIDTHS", "REFIT_SETTINGS", "ROUNDS_M",
    "SPLINE_TIE_SE", "TIE_SE",
    "RefitChoice", "RefitSetting", "agreement_tolerance", "choose_refit", "echo_points",
    "hull_tolerance", "main_body", "range_noise", "references", "refit_profile",
    "simplest_agreeing", "tie_reasons", "tied_settings", "tolerances", "undominated",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]

#: A refit needs at least this many echo points in its first round: fewer say that the
#: profile is not the surface the readings see (a room's log, one wall's y(x)).
MIN_ECHO_POINTS = 10
#: The echo points are searched for on at most this many (reading, profile sample) pairs:
#: a longer log's readings are subsampled (seeded) so that the refit stays a few runs.
MAX_PAIRS = 5_000_000


@dataclass
class RefitChoice:
    """The echo refit's settings, their held-out residuals, and the verdict."""

    criterion: str
    residuals: dict[RefitSetting, float] = field(default_factory=dict)
    excluded: dict[RefitSetting, str] = field(default_factory=dict)
    #: the setting with the lowest held-out residual
    best: RefitSetting | None = None
    applied: bool = False
    reason: str = ""
    fit: Fit | None = None
    #: x (m) of the outermost echo points of the chosen refit
    echo_span: tuple[float, float] | None = None
    #: every setting's refit on all the readings, its echo span, the x (m) of its echo
    #: columns and its held-out losses (for studies)
    fits: dict[RefitSetting, Profile] = field(default_factory=dict)
    spans: dict[RefitSetting, tuple[float, float]] = field(default_factory=dict)
    echo_x: dict[RefitSetting, FloatArray] = field(default_factory=dict)
    losses: dict[RefitSetting, FloatArray] = field(default_factory=dict)
    #: the settings tied with the best, and why each is (:func:`tie_reasons`)
    tied_why: dict[RefitSetting, str] = field(default_factory=dict)
    #: the tied splines averaged into ``fit`` (one setting: that refit alone)
    averaged: tuple[RefitSetting, ...] = ()
    #: why a polynomial was taken over the tied splines (:func:`simplest_agreeing`)
    simpler: str = ""
    #: held-out residual (m) of ``fit``: the setting's, or the average's
    residual: float | None = None
    #: the readings' range noise about the starting profile (m; :func:`range_noise`) and
    #: the rounds' range tolerances (m) it set
    noise: float | None = None
    tolerances: tuple[float, ...] = ()
    #: the noise estimate about the starting profile, when it was above
    #: :data:`NOISE_MAX` and ``noise`` was estimated again about the best refit
    noise_start: float | None = None
    #: held-out losses of ``fit``, in the order of the folds (for comparing refits)
    heldout: FloatArray | None = None

    @property
    def tied(self) -> tuple[RefitSetting, ...]:
        """The settings tied with the best (the best among them), in order."""
        return tuple(sorted(self.tied_why))

    @property
    def setting(self) -> RefitSetting | None:
        """The refit's setting (of the averaged splines, the one with the lowest held-out
        residual); None if no refit was scored."""
        if not self.averaged:
            return None
        return min(self.averaged, key=lambda k: self.residuals[k])

    @property
    def fit_short(self) -> str | None:
        """The refit in a few words: ``spline L=0.2 m``, ``poly m=6``, or the splines
        averaged."""
        if len(self.averaged) > 1:
            return "mean of splines L=" + ", ".join(f"{k.value:g}" for k in self.averaged) + " m"
        return None if self.setting is None else self.setting.short

    def to_json(self) -> dict[str, Any]:
        """JSON-ready mapping for the ``--auto`` record's ``echo_refit``.

        ``smoothing_length_m`` and ``averaged_lengths_m`` name the spline refit (None and
        empty when a polynomial is chosen); ``polynomial_order`` names a polynomial's.
        """
        setting = self.setting
        return {
            "criterion": self.criterion,
            "residuals_m": {k.short: _finite(v) for k, v in self.residuals.items()},
            "excluded": {k.short: v for k, v in self.excluded.items()},
            "setting": None if setting is None else setting.short,
            "smoothing_length_m": _value_of(setting, "spline"),
            "polynomial_order": _value_of(setting, "poly"),
            "tied": [k.short for k in self.tied],
            "tied_why": {k.short: v for k, v in self.tied_why.items()},
            "averaged_lengths_m": [k.value for k in self.averaged if k.family == "spline"],
            "simpler": self.simpler,
            "residual_m": None if self.residual is None else _finite(self.residual),
            "fit_short": self.fit_short,
            "applied": self.applied,
            "reason": self.reason,
            "echo_span_m": None if self.echo_span is None else list(self.echo_span),
            "range_noise_m": None if self.noise is None else _finite(self.noise),
            "range_noise_start_m": None if self.noise_start is None else _finite(self.noise_start),
            "tolerances_m": list(self.tolerances),
        }


def _value_of(setting: RefitSetting | None, family: str) -> float | int | None:
    if setting is None or setting.family != family:
        return None
    return int(setting.value) if family == "poly" else setting.value


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def choose_refit(
    fit: Fit,
    map_bins: Bins,
    beams: Beams,
    grid: Grid,
    *,
    chosen_residual: float,
    chosen_losses: FloatArray | None = None,
    folds: int = 4,
    repeats: int = 1,
    heldout_per_fold: int = 300,
    cap: float,
    seed: int = 0,
    settings: tuple[RefitSetting, ...] = REFIT_SETTINGS,
    noise: float | None = None,
    splits: list[Split] | None = None,
) -> RefitChoice:
    """Choose the echo refit's curve by the held-out range residual.

    The settings whose residuals are close to the lowest cannot be told apart by the
    readings (:func:`tied_settings`). Among them the lowest-order polynomial
    that agrees with the most flexible tied refit wherever readings echo is taken
    (:func:`simplest_agreeing`); failing one, the tied splines' refits are averaged. The
    refit is applied when its residual is below the chosen candidate's, or above it by
    less than :data:`TIE_SE` paired standard errors (it removes the map's bias, which the
    readings alone may not show).

    Parameters
    ----------
    fit : Fit
        The chosen candidate's profile on every scored reading.
    map_bins : Bins
        Its map's points per column (they fill the columns no reading echoes from).
    beams : Beams
        The scored readings (the same folds as the candidates' are drawn from ``seed``).
    grid : Grid
        The map's grid.
    chosen_residual : float
        The chosen candidate's held-out residual (m): the refit must beat it.
    chosen_losses : ndarray, optional
        The chosen candidate's held-out losses, in the order of the folds: with them a
        refit within :data:`TIE_SE` paired standard errors of the candidate is applied.
    folds, repeats, heldout_per_fold, cap, seed
        As :func:`sonarproc.auto.choose`.
    settings : tuple of RefitSetting
        The refits tried (:data:`REFIT_SETTINGS`).
    noise : float, optional
        The readings' range noise (m) that sets the rounds' tolerances
        (:func:`tolerances`); by default :func:`range_noise` about ``fit``.
    splits : list of Split, optional
        The folds the candidates were scored on (:attr:`sonarproc.auto.AutoChoice.splits`):
        the refit's held-out losses then pair with ``chosen_losses`` reading by reading,
        whatever options drew them; by default drawn from ``folds``, ``repeats``,
        ``heldout_per_fold`` and ``seed`` as :func:`sonarproc.auto.choose` draws them.

    Returns
    -------
    RefitChoice
    """
    criterion = (
        "the chosen profile refitted through the readings' echo points (smoothing splines "
        "and polynomials, scored by the same held-out range residual; among those tied "
        f"with the best (smoothing lengths within {SPLINE_TIE_SE:g} paired standard error "
        "over firings, or next to the best and better on the readings both predict while "
        f"the best predicts more; other refits within {TIE_SE:g} over readings), the "
        "lowest-order polynomial that agrees wherever readings echo with the most flexible "
        "tied spline, or with the best refit if that is a polynomial, else the tied splines "
        "averaged); applied "
        "unless its residual is above the chosen candidate's by more than "
        f"{TIE_SE:g} paired standard errors"
    )
    out = RefitChoice(criterion)
    occupied = np.flatnonzero(map_bins.count > 0)
    if not isinstance(fit, (PolyFit, SplineFit)) or occupied.size < 2:
        out.reason = "no profile y(x) to refit"
        return out
    span = (float(map_bins.centres[occupied[0]]), float(map_bins.centres[occupied[-1]]))
    if splits is None:
        # the held-out readings of the candidates' folds (same seeds, same order of draws)
        splits = heldout_splits(beams.readings, folds, repeats, heldout_per_fold, seed=seed)
    samples = int((span[1] - span[0]) / grid.cell) + 1
    echoing = beams
    if len(beams.path) * samples > MAX_PAIRS:
        keep = np.random.default_rng(seed + 3).random(len(beams.path)) < MAX_PAIRS / (
            len(beams.path) * samples
        )
        echoing = subset_beams(beams, keep)
        # the folds are the readings' own: carry them over to the subset
        splits = [(train[keep], held) for train, held in splits]
    out.noise = range_noise(fit, echoing, grid.cell) if noise is None else noise
    fold_curves = _score_settings(
        out, fit, map_bins, beams, echoing, grid, span, splits, settings, cap
    )
    if fold_curves is None:
        return out
    if out.residuals and out.noise > NOISE_MAX:
        # Above NOISE_MAX the estimate says that the profile misses most readings (a
        # room's other walls), or that the start is far off on a noisy log: about the
        # best refit the second comes down to the noise, the first does not.
        best = min(out.residuals, key=lambda k: out.residuals[k])
        again = range_noise(out.fits[best], echoing, grid.cell)
        if believable_noise(again) and tolerances(again) != out.tolerances:
            retry = RefitChoice(criterion, noise=again, noise_start=out.noise)
            curves = _score_settings(
                retry, fit, map_bins, beams, echoing, grid, span, splits, settings, cap
            )
            if curves is not None and retry.residuals:
                out, fold_curves = retry, curves
    fits, spans = out.fits, out.spans
    if not out.residuals:
        out.reason = (
            "every refit leaves its points' hull" if out.excluded
            else "no reading echoes from the chosen profile"
        )  # fmt: skip
        return out
    held = np.concatenate([h for _, h in splits]) if splits else np.zeros(0, np.intp)
    _settle_ties(out, echoing, grid.cell, firing_index(beams.readings)[held], cap)
    if len(out.averaged) == 1:
        one = out.averaged[0]
        refit, losses, out.echo_span = fits[one], out.losses[one], spans[one]
    else:
        refit = _mean_profile([fits[k] for k in out.averaged], span, grid.cell)
        mean_curves = [
            _mean_curve([fold_curves[k][i] for k in out.averaged]) for i in range(len(splits))
        ]
        losses = _heldout_losses(mean_curves, splits, beams, cap)
        # where every averaged refit is carried by echo points
        out.echo_span = (
            max(spans[k][0] for k in out.averaged),
            min(spans[k][1] for k in out.averaged),
        )
    out.residual, out.heldout = robust_residual(losses), losses
    close = chosen_losses is not None and out.residual - chosen_residual <= TIE_SE * np.nan_to_num(
        paired_se(chosen_losses, losses)
    )
    verdict = f"held-out residual {100 * out.residual:.3g} cm"
    theirs = f"the chosen candidate's {100 * chosen_residual:.3g} cm"
    within = f"{TIE_SE:g} paired standard errors of"
    if out.residual < chosen_residual:
        out.applied, out.fit, out.reason = True, refit, f"{verdict} below {theirs}"
    elif close:
        out.applied, out.fit, out.reason = True, refit, f"{verdict} within {within} {theirs}"
    else:
        out.reason = f"{verdict} not below {theirs}" + (
            "" if chosen_losses is None else f", nor within {within} it"
        )
    if out.simpler:
        out.reason += "; " + out.simpler
    for k in out.averaged:
        why = out.tied_why.get(k, "")
        if why.startswith(NEIGHBOUR_TIE) and out.best is not None:
            counts = why.removeprefix(NEIGHBOUR_TIE)
            out.reason += f"; {k.short} tied with {out.best.short}: {counts}"
    return out


def _settle_ties(
    out: RefitChoice, beams: Beams, cell: float, firings: npt.NDArray[np.intp], cap: float
) -> None:
    """Set ``out``'s best setting, the settings tied with it (:func:`tied_settings`;
    ``firings``: each held-out loss's firing; ``cap``: the losses' cap, m), and the refit
    taken: the lowest-order tied polynomial that agrees with a reference (:func:`references`,
    :func:`simplest_agreeing`), else the tied splines (averaged)."""
    best = min(out.residuals, key=lambda k: out.residuals[k])
    out.best = best
    out.tied_why = tie_reasons(out.residuals, out.losses, firings, cap)
    for reference in references(out.tied, best):
        # the noise about the refit, not about the start: a start's bias is no noise
        tolerance = agreement_tolerance(range_noise(out.fits[reference], beams, cell), cell)
        simplest = simplest_agreeing(
            out.tied, reference, out.fits, out.echo_x, out.spans, tolerance
        )
        if simplest is None:
            continue
        poly, gap = simplest
        out.averaged = (poly,)
        if poly != reference:
            out.simpler = (
                f"{poly.short}: the lowest-order polynomial among the {len(out.tied)} tied "
                f"refits, within {100 * gap:.2g} cm (at most {100 * tolerance:.2g}) of "
                f"{reference.short} wherever readings echo"
            )
        elif len(out.tied) > 1:
            out.simpler = (
                f"{poly.short}: the best of the {len(out.tied)} tied refits; no tied spline "
                "agrees with it, nor a polynomial of a lower order, wherever readings echo"
            )
        return
    out.averaged = tuple(k for k in out.tied if k.family == "spline")


def _score_settings(
    out: RefitChoice,
    fit: Profile,
    map_bins: Bins,
    beams: Beams,
    echoing: Beams,
    grid: Grid,
    span: Span,
    splits: list[Split],
    settings: tuple[RefitSetting, ...],
    cap: float,
) -> dict[RefitSetting, list[FloatArray | None]] | None:
    """Refit every setting from ``fit`` with the tolerances of ``out.noise`` and score it on
    the folds, into ``out``; returns each setting's fold curves (None, with ``out.reason``,
    when too few readings echo from ``fit``)."""
    out.tolerances = tols = tolerances(out.noise or 0.0)
    # the first round starts from the chosen fit whatever the setting: search it once
    first = echo_points(fit, echoing, span, step=grid.cell, tol=tols[0])
    if first[0].size < MIN_ECHO_POINTS:
        out.reason = (
            f"{first[0].size} readings echo from the chosen profile "
            f"(at least {MIN_ECHO_POINTS} needed)"
        )
        return None
    fold_curves: dict[RefitSetting, list[FloatArray | None]] = {}
    for setting in settings:
        whole, rows, points = refit_profile(
            fit, map_bins, echoing, grid, span, setting, first=first, tols=tols
        )
        if not isinstance(whole, (PolyFit, SplineFit)) or rows.size == 0:
            continue
        hull = fitted_points(points, map_bins, grid)
        curve = whole.sample(grid.cell)
        excess = hull_excess(
            curve, hull[:, 0], hull[:, 1], window=HULL_WINDOW_CELLS * grid.cell,
            side=sensor_side(echoing, curve),
        )  # fmt: skip
        if excess > hull_tolerance(out.noise or 0.0, grid.cell):
            out.excluded[setting] = f"leaves its points' hull by {100 * excess:.3g} cm"
            continue
        curves: list[FloatArray | None] = []
        for train, _ in splits:
            part = fit_points(points[train[rows]], map_bins, grid, setting)
            ok = isinstance(part, (PolyFit, SplineFit))
            curves.append(sample_curve(part, span, grid.cell) if ok else None)  # type: ignore[arg-type]
        if splits:
            fold_curves[setting] = curves
            out.losses[setting] = _heldout_losses(curves, splits, beams, cap)
            out.residuals[setting] = robust_residual(out.losses[setting])
            out.fits[setting] = whole
            out.spans[setting] = (float(points[:, 0].min()), float(points[:, 0].max()))
            _, ix = grid.to_index(points[:, 0], 0.0)
            out.echo_x[setting] = grid.centres_x()[np.unique(np.clip(ix, 0, grid.nx - 1))]
    return fold_curves


def _heldout_losses(
    curves: list[FloatArray | None],
    splits: list[Split],
    beams: Beams,
    cap: float,
) -> FloatArray:
    """Each fold's held-out readings' losses against its curve (the cap for a failed fit)."""
    losses = [
        np.full(held.size, cap) if curve is None
        else range_loss(beams.path[held], curve_path(curve, beams, held), cap)
        for curve, (_, held) in zip(curves, splits, strict=True)
    ]  # fmt: skip
    return np.concatenate(losses) if losses else np.zeros(0)


def _mean_curve(curves: list[FloatArray | None]) -> FloatArray | None:
    """The pointwise mean of sampled curves on the same abscissae (None if one is missing)."""
    present = [c for c in curves if c is not None]
    if not present or len(present) < len(curves):
        return None
    return np.column_stack((present[0][:, 0], np.mean([c[:, 1] for c in present], axis=0)))


def _mean_profile(fits: list[Profile], span: Span, step: float) -> SplineFit:
    """The pointwise mean of profiles, as a cubic spline through it every ``step``."""
    from scipy.interpolate import make_interp_spline

    mean = _mean_curve([sample_curve(f, span, step) for f in fits])
    assert mean is not None
    xs, ys = mean[:, 0], mean[:, 1]
    degree = min(3, xs.size - 1)
    spl = make_interp_spline(xs, ys, k=degree)
    return SplineFit(
        knots=np.asarray(spl.t, dtype=np.float64), coef=np.asarray(spl.c, dtype=np.float64),
        degree=degree, domain=(float(xs[0]), float(xs[-1])), lam=None,
    )  # fmt: skip
