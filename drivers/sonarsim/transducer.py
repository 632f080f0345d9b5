"""Transducer physics: beam pattern, detection threshold and time walk of a Polaroid sonar.

The ``ideal`` physics (the paper's) hears a specular echo at its exact range whenever
the reflection point lies inside a hard-edged beam of the nominal half-width. The
``transducer`` physics follows the measured behaviour of Polaroid 600-series ranging
transducers (Kuc & Siegel 1987; Barshan & Kuc 1990; Leonard & Durrant-Whyte 1991;
Kleeman & Kuc 1995):

Directivity
    A circular piston of radius ``a`` at frequency ``f`` (wavenumber ``k = 2 pi f / c``)
    has the far-field pattern ``D(theta) = 2 J1(ka sin theta) / (ka sin theta)``
    (Kuc & Siegel 1987). ``beam_model: piston`` uses it inside the main lobe (zero past
    the first null, ``ka sin theta = 3.8317``; side lobes are ignored);
    ``beam_model: gaussian`` (default) uses the Gaussian that matches the lobe's
    curvature on the axis, ``D = exp(-(ka sin theta)^2 / 8)`` (Barshan & Kuc 1990), which
    has no null and so lets strong near echoes be heard past the nominal half-width.
    With ``a = 19 mm``, ``f = 49.4 kHz`` and ``c = 343 m/s``, ``ka = 17.2`` and the first
    null lies at 12.9 degrees, which caps the piston model's effective beam there.
Echo amplitude
    Relative to the head-on echo of a perfect plane at ``reference_range``:
    ``A = rho D(theta_tx) D(theta_rx) (r_ref / r)^n`` where ``theta`` is the angle of the
    echo's arrival direction off each transducer's axis, ``rho`` the reflector's
    reflectivity and ``n`` its spreading exponent: 2 for a specular plane (round trip in
    image geometry), a concave corner (two specular bounces, same image geometry) and a
    cylinder's facing point (times its horizontal divergence ``R / (R + r)``, see
    :func:`sonarsim.physical_echoes.cylinder_divergence`); 3 for a
    diffracting convex edge, whose echo is a weak point source (Kuc & Siegel 1987 find
    edge echoes fall off faster than plane echoes and are heard only close by).
Detection threshold
    An echo is heard when ``A >= threshold``. The default ``0.014`` puts the effective
    beam edge of a plane at 12.5 degrees at 1.5 m (the nominal half-width, Leonard &
    Durrant-Whyte 1991), 16.1 degrees at 0.5 m, 13.9 at 1 m, 11.4 at 2 m and 8.2 at 4 m;
    a head-on plane is heard up to ``r_ref / sqrt(threshold)`` = 8.5 m, a head-on
    diffracting edge up to ``(edge_reflectivity / threshold)^(1/3)`` = 1.5 m.
Time walk
    The receiver's envelope rises linearly over ``rise_time_s`` and the board times the
    echo where it crosses the threshold (Kleeman & Kuc 1995), so an echo of amplitude
    ``A`` crosses it ``rise_time_s * threshold / A`` late: the range reads long by
    ``c rise_time_s threshold / (2 A)``. The default ``87 us`` gives 1.5 cm at the beam
    edge (``A = threshold``), under 0.3 mm for a head-on plane at 1 m.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import j1

from sonarsim.geometry import FloatArray

PISTON_FIRST_NULL = 3.8317059702075125
"""First zero of J1: the piston's main lobe ends where ``ka sin theta`` reaches it."""


@dataclass(frozen=True)
class TransducerParams:
    """Named SI parameters of the transducer physics (defaults: Polaroid 600-series).

    Attributes
    ----------
    beam_model : {"gaussian", "piston"}
        Main-lobe directivity model.
    frequency_hz : float
        Carrier frequency (Hz); Polaroid 49.4 kHz.
    piston_radius : float
        Radiating face radius ``a`` (m); Polaroid 600-series about 19 mm.
    threshold : float
        Detection threshold relative to the head-on plane echo at ``reference_range``.
    reference_range : float
        Range (m) at which a head-on perfect plane gives amplitude 1.
    rise_time_s : float
        Envelope rise time (s) behind the time walk.
    plane_reflectivity, corner_reflectivity, edge_reflectivity : float
        Amplitude factors of specular surfaces, concave right-angle corners and
        diffracting edges.
    edge_spreading_exponent : float
        ``n`` in ``(r_ref / r)^n`` for diffracting edges (planes and corners use 2).
    corner_angle_tolerance_deg : float
        A concave vertex retro-reflects when its opening is within this of 90 degrees
        (the double bounce returns within the main lobe); other vertices diffract.
    """

    beam_model: Literal["gaussian", "piston"] = "gaussian"
    frequency_hz: float = 49_400.0
    piston_radius: float = 0.019
    threshold: float = 0.014
    reference_range: float = 1.0
    rise_time_s: float = 87e-6
    plane_reflectivity: float = 1.0
    corner_reflectivity: float = 1.0
    edge_reflectivity: float = 0.05
    edge_spreading_exponent: float = 3.0
    corner_angle_tolerance_deg: float = 15.0

    def ka(self, speed_of_sound: float) -> float:
        """The piston's ``k a`` at this speed of sound."""
        return 2.0 * np.pi * self.frequency_hz / speed_of_sound * self.piston_radius


def directivity(theta: ArrayLike, ka: ArrayLike, model: str = "gaussian") -> FloatArray:
    """Main-lobe pressure directivity ``D(theta)`` (1 on the axis).

    Examples
    --------
    >>> float(directivity(0.0, 17.2)[()])
    1.0
    >>> float(directivity(np.deg2rad(20.0), 17.2, "piston")[()])
    0.0
    """
    x = np.asarray(ka, dtype=np.float64) * np.abs(np.sin(np.asarray(theta, dtype=np.float64)))
    if model == "gaussian":
        return np.asarray(np.exp(-(x**2) / 8.0))
    if model != "piston":
        raise ValueError(f"beam_model must be 'gaussian' or 'piston', got {model!r}")
    safe = np.where(x > 1e-9, x, 1.0)
    d = np.where(x > 1e-9, 2.0 * j1(safe) / safe, 1.0)
    return np.asarray(np.where(x < PISTON_FIRST_NULL, d, 0.0))


def main_lobe_amplitude(
    theta_tx: ArrayLike, theta_rx: ArrayLike, r: ArrayLike, ka: ArrayLike, *,
    model: str = "gaussian", reflectivity: ArrayLike = 1.0, exponent: ArrayLike = 2.0,
    reference_range: float = 1.0,
) -> FloatArray:  # fmt: skip
    """Echo amplitude through the main lobe with spreading: ``rho D(tx) D(rx) (r_ref / r)^n``.

    The one echo-amplitude model of the package and of the processing that undoes its
    time walk: the directivity of the transmitter and of the receiver
    (:func:`directivity`; the Gaussian main lobe ``exp(-(ka sin theta)^2 / 8)`` of
    Barshan & Kuc 1990 by default) times the spreading loss ``(r_ref / r)^n`` (``n = 2``
    for a specular plane or a retro-reflecting corner in image geometry; Kuc & Siegel
    1987).

    Parameters
    ----------
    theta_tx, theta_rx : array_like
        Angles (rad) of the echo's path off the transmitter's and the receiver's axis.
    r : array_like
        One-way distance (m) to the reflector.
    ka : array_like
        The piston's wavenumber times radius (``k a``), one or one per echo.
    model : {"gaussian", "piston"}
        Main-lobe directivity model.
    reflectivity : array_like
        Amplitude factor ``rho`` of the reflector.
    exponent : array_like
        Spreading exponent ``n``.
    reference_range : float
        Range (m) at which a head-on perfect plane gives amplitude 1.

    Returns
    -------
    ndarray
        The amplitude relative to the head-on plane echo at ``reference_range``.

    Examples
    --------
    On the axis at 2 m, then 6 degrees off both axes there (``ka = 17.2``):

    >>> theta = np.radians([0.0, 6.0])
    >>> main_lobe_amplitude(theta, theta, 2.0, 17.2).round(4).tolist()
    [0.25, 0.1114]
    """
    d = directivity(theta_tx, ka, model) * directivity(theta_rx, ka, model)
    rr = reference_range / np.maximum(np.asarray(r, dtype=np.float64), 1e-6)
    return np.asarray(np.asarray(reflectivity) * d * rr ** np.asarray(exponent))


def amplitude(
    theta_tx: ArrayLike, theta_rx: ArrayLike, r: ArrayLike, reflectivity: ArrayLike,
    exponent: ArrayLike, params: TransducerParams, speed_of_sound: float,
) -> FloatArray:  # fmt: skip
    """Echo amplitude relative to a head-on plane at ``reference_range``.

    ``theta_tx``, ``theta_rx`` are the angles (rad) off each transducer's axis, ``r`` the
    one-way distance (m), ``exponent`` the spreading exponent: :func:`main_lobe_amplitude`
    with the transducer's ``ka``, beam model and reference range.
    """
    return main_lobe_amplitude(
        theta_tx, theta_rx, r, params.ka(speed_of_sound), model=params.beam_model,
        reflectivity=reflectivity, exponent=exponent, reference_range=params.reference_range,
    )  # fmt: skip


def time_walk(amp: ArrayLike, params: TransducerParams, speed_of_sound: float) -> FloatArray:
    """Range bias (m) of an echo of relative amplitude ``amp`` (>= threshold).

    ``c rise_time_s threshold / (2 amp)``: the linear envelope crosses the threshold late.

    Examples
    --------
    >>> p = TransducerParams()
    >>> round(float(time_walk(p.threshold, p, 343.0)[()]), 4)
    0.0149
    """
    a = np.maximum(np.asarray(amp, dtype=np.float64), params.threshold)
    return np.asarray(0.5 * speed_of_sound * params.rise_time_s * params.threshold / a)


def search_half_angle(params: TransducerParams, min_range: float, speed_of_sound: float) -> float:
    """Widest angle off the axis (rad) at which any echo can be heard.

    The strongest echo at angle ``theta`` is a perfect plane or corner at the blanking
    range ``min_range``; beyond the angle where even it falls under the threshold
    nothing is heard. Used to bound the geometric search.
    """
    ka = params.ka(speed_of_sound)
    r = max(min_range, 0.05)
    strongest = max(params.plane_reflectivity, params.corner_reflectivity, 1e-12)
    need = params.threshold * (r / params.reference_range) ** 2 / strongest
    if need >= 1.0:
        return 1e-3
    # D(theta)^2 = need (monostatic): invert the model.
    if params.beam_model == "gaussian":
        x = float(np.sqrt(-4.0 * np.log(need)))
    else:
        x = PISTON_FIRST_NULL
    s = min(x / ka, np.sin(np.deg2rad(89.0)))
    return float(np.arcsin(s))
