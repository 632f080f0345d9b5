"""Reflecting surfaces and their discretisation into segments.

Every surface becomes a run of straight segments for the echo search
(:class:`~sonarsim.segments.Segments`). A segment carries the unit tangents at both ends:
for *flat* segments (walls, polylines, rooms) both are the segment direction and
reflections are computed exactly by mirror images; for *smooth* segments (samples of a
curve or circle) they are the true curve tangents at the samples, so a specular point is
found between samples even on convex curves, and the reflection point and path length are
accurate to far below a millimetre at 1 cm sampling.

Surface types: :class:`Polyline` (straight walls and rooms are polylines, see
:func:`wall` and :func:`room`), :class:`Curve` (``y = f(x)``: see :func:`polynomial`,
:func:`sinusoid`, :func:`profile`), :class:`Circle` (a cylinder seen from above) and
:class:`SmoothPolyline` (any sampled smooth curve with tangents).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sonarsim.geometry import FloatArray, rotate, unit
from sonarsim.segments import DEFAULT_RESOLUTION, Segments, Surface

__all__ = [
    "DEFAULT_RESOLUTION",
    "Circle",
    "Curve",
    "Polyline",
    "Segments",
    "SmoothPolyline",
    "Surface",
    "polynomial",
    "profile",
    "room",
    "sinusoid",
    "wall",
]


def _as_points(points: ArrayLike, minimum: int) -> FloatArray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < minimum:
        raise ValueError(f"need an (N, 2) array of at least {minimum} points, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    return p


def _densify(points: FloatArray, spacing: float) -> FloatArray:
    """Insert points along each straight piece so no gap exceeds ``spacing``."""
    d = np.diff(points, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(d[:, 0], d[:, 1]) / spacing).astype(np.intp))
    starts = np.repeat(points[:-1], n, axis=0)
    steps = np.repeat(d / n[:, None], n, axis=0)
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    return np.concatenate([starts + steps * k[:, None], points[-1:]])


@dataclass(frozen=True)
class Polyline:
    """Straight pieces through ``points`` (a wall, a room, a faceted object).

    Parameters
    ----------
    points : array_like, shape (M, 2)
        Vertices in metres (M >= 2).
    closed : bool
        Join the last vertex back to the first.
    name : str
        Optional label.
    truth : bool
        Whether the surface belongs in the truth profile of a simulation.
    """

    points: FloatArray
    closed: bool = False
    name: str = ""
    truth: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", _as_points(self.points, 2))

    def _vertices(self) -> FloatArray:
        return np.vstack([self.points, self.points[:1]]) if self.closed else self.points

    def segments(self, resolution: float = DEFAULT_RESOLUTION) -> Segments:
        """One flat segment per straight piece (resolution is not needed)."""
        v = self._vertices()
        a, b = v[:-1], v[1:]
        t, length = unit(b - a)
        keep = length > 0.0
        a, b, t = a[keep], b[keep], t[keep]
        return Segments(a, b, t, t.copy(), np.ones(len(a), bool), np.zeros(len(a), np.intp))

    def sample(self, spacing: float = DEFAULT_RESOLUTION) -> FloatArray:
        """Vertices with extra points so consecutive points are at most ``spacing`` apart."""
        return _densify(self._vertices(), spacing)

    def transformed(
        self, angle: float, offset: ArrayLike, resolution: float = DEFAULT_RESOLUTION
    ) -> Polyline:
        """Rigidly moved copy."""
        pts = rotate(self.points, angle) + np.asarray(offset, dtype=np.float64)
        return Polyline(pts, self.closed, self.name, self.truth)


@dataclass(frozen=True)
class SmoothPolyline:
    """A smooth curve given by samples and the unit tangents there.

    Between samples the reflection search interpolates the tangent, so specular points
    are found anywhere along the curve, not only at samples.
    """

    points: FloatArray
    tangents: FloatArray
    closed: bool = False
    name: str = ""
    truth: bool = True

    def __post_init__(self) -> None:
        p = _as_points(self.points, 2)
        t = _as_points(self.tangents, 2)
        if t.shape != p.shape:
            raise ValueError("tangents must match points in shape")
        object.__setattr__(self, "points", p)
        object.__setattr__(self, "tangents", unit(t)[0])

    def segments(self, resolution: float = DEFAULT_RESOLUTION) -> Segments:
        """One smooth segment between consecutive samples."""
        p, t = self.points, self.tangents
        if self.closed:
            p, t = np.vstack([p, p[:1]]), np.vstack([t, t[:1]])
        n = len(p) - 1
        return Segments(p[:-1], p[1:], t[:-1], t[1:], np.zeros(n, bool), np.zeros(n, np.intp))

    def sample(self, spacing: float = DEFAULT_RESOLUTION) -> FloatArray:
        """The samples, densified linearly if they are further apart than ``spacing``."""
        p = np.vstack([self.points, self.points[:1]]) if self.closed else self.points
        return _densify(p, spacing)

    def transformed(
        self, angle: float, offset: ArrayLike, resolution: float = DEFAULT_RESOLUTION
    ) -> SmoothPolyline:
        """Rigidly moved copy."""
        pts = rotate(self.points, angle) + np.asarray(offset, dtype=np.float64)
        return SmoothPolyline(pts, rotate(self.tangents, angle), self.closed, self.name, self.truth)


@dataclass(frozen=True)
class Curve:
    """A curve ``y = f(x)`` on ``x_min <= x <= x_max``.

    Parameters
    ----------
    f, df : callable
        The function and its derivative, vectorised over numpy arrays (m -> m).
    x_min, x_max : float
        The curve's extent in x (m).
    kind : str
        What made it (``polynomial``, ``sinusoid``, ``profile``), for messages.
    """

    f: Callable[[FloatArray], FloatArray]
    df: Callable[[FloatArray], FloatArray]
    x_min: float
    x_max: float
    kind: str = "curve"
    name: str = ""
    truth: bool = True
    params: dict[str, object] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.x_min) and np.isfinite(self.x_max) and self.x_max > self.x_min):
            raise ValueError(f"x range must be increasing, got [{self.x_min}, {self.x_max}]")

    def xs(self, spacing: float) -> FloatArray:
        """Abscissae, increasing, whose points are at most ``spacing`` apart along the curve."""
        fine = np.linspace(self.x_min, self.x_max, 64 * 1024 + 1)
        speed = np.sqrt(1.0 + self.df(fine) ** 2)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(fine))])
        n = max(1, int(np.ceil(s[-1] / (0.999 * spacing))))
        return np.asarray(np.interp(np.linspace(0.0, s[-1], n + 1), s, fine), dtype=np.float64)

    def sample(self, spacing: float = DEFAULT_RESOLUTION) -> FloatArray:
        """Points sorted by x, at most ``spacing`` apart along the curve."""
        x = self.xs(spacing)
        return np.stack([x, self.f(x)], axis=1)

    def smooth(self, resolution: float = DEFAULT_RESOLUTION) -> SmoothPolyline:
        """Samples with exact tangents."""
        x = self.xs(resolution)
        tangents = np.stack([np.ones_like(x), self.df(x)], axis=1)
        return SmoothPolyline(
            np.stack([x, self.f(x)], axis=1), tangents, False, self.name, self.truth
        )

    def segments(self, resolution: float = DEFAULT_RESOLUTION) -> Segments:
        """Smooth segments at most ``resolution`` long."""
        return self.smooth(resolution).segments()

    def transformed(
        self, angle: float, offset: ArrayLike, resolution: float = DEFAULT_RESOLUTION
    ) -> SmoothPolyline:
        """Rigidly moved copy (no longer a function of x, so a sampled smooth curve)."""
        return self.smooth(resolution).transformed(angle, offset)


def polynomial(
    coefficients: Sequence[float],
    x_range: tuple[float, float],
    *,
    name: str = "",
    truth: bool = True,
) -> Curve:
    """``y = c0 + c1 x + c2 x^2 + ...`` (ascending powers, metres).

    Examples
    --------
    >>> c = polynomial([1.0, 0.0, 0.5], (-1.0, 1.0))
    >>> float(c.f(np.array(2.0)))
    3.0
    """
    c = np.asarray(coefficients, dtype=np.float64)
    if c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
        raise ValueError("polynomial coefficients must be a non-empty list of finite numbers")
    poly = np.polynomial.Polynomial(c)
    deriv = poly.deriv()

    def f(x: FloatArray) -> FloatArray:
        return np.asarray(poly(x), dtype=np.float64)

    def df(x: FloatArray) -> FloatArray:
        return np.asarray(deriv(x), dtype=np.float64) * np.ones_like(x)

    return Curve(
        f, df, float(x_range[0]), float(x_range[1]), "polynomial", name, truth,
        {"coefficients": c.tolist()},
    )  # fmt: skip


def sinusoid(
    amplitude: float,
    period: float,
    x_range: tuple[float, float],
    *,
    offset: float = 0.0,
    phase: float = 0.0,
    name: str = "",
    truth: bool = True,
) -> Curve:
    """``y = offset + amplitude * sin(2 pi x / period + phase)`` (metres, radians)."""
    if not period > 0.0:
        raise ValueError(f"sinusoid period must be > 0, got {period}")
    k = 2.0 * np.pi / period

    def f(x: FloatArray) -> FloatArray:
        return np.asarray(offset + amplitude * np.sin(k * x + phase), dtype=np.float64)

    def df(x: FloatArray) -> FloatArray:
        return np.asarray(amplitude * k * np.cos(k * x + phase), dtype=np.float64)

    return Curve(f, df, float(x_range[0]), float(x_range[1]), "sinusoid", name, truth)


def profile(points: ArrayLike, *, name: str = "", truth: bool = True) -> Curve:
    """A sampled profile ``(x, y)`` (x strictly increasing) through a cubic spline."""
    from scipy.interpolate import CubicSpline, PchipInterpolator

    p = _as_points(points, 2)
    if np.any(np.diff(p[:, 0]) <= 0.0):
        raise ValueError("profile x values must be strictly increasing")
    spline = CubicSpline(p[:, 0], p[:, 1], bc_type="natural") if len(p) > 2 else None
    interp = spline if spline is not None else PchipInterpolator(p[:, 0], p[:, 1])
    deriv = interp.derivative()

    def f(x: FloatArray) -> FloatArray:
        return np.asarray(interp(x), dtype=np.float64)

    def df(x: FloatArray) -> FloatArray:
        return np.asarray(deriv(x), dtype=np.float64)

    return Curve(f, df, float(p[0, 0]), float(p[-1, 0]), "profile", name, truth)


@dataclass(frozen=True)
class Circle:
    """A circle (a cylinder seen from above), reflecting on its outside and inside."""

    center: tuple[float, float]
    radius: float
    name: str = ""
    truth: bool = True
    phase: float = 0.0
    """Angle of the first sample (rad); rotating the circle rotates its samples too."""

    def __post_init__(self) -> None:
        if not self.radius > 0.0:
            raise ValueError(f"circle radius must be > 0, got {self.radius}")

    def smooth(self, resolution: float = DEFAULT_RESOLUTION) -> SmoothPolyline:
        """Samples with exact tangents (counter-clockwise)."""
        n = max(8, int(np.ceil(2.0 * np.pi * self.radius / (0.999 * resolution))))
        phi = self.phase + np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
        c = np.asarray(self.center, dtype=np.float64)
        pts = c + self.radius * np.stack([np.cos(phi), np.sin(phi)], axis=1)
        tan = np.stack([-np.sin(phi), np.cos(phi)], axis=1)
        return SmoothPolyline(pts, tan, True, self.name, self.truth)

    def segments(self, resolution: float = DEFAULT_RESOLUTION) -> Segments:
        """Smooth chords at most ``resolution`` long."""
        return self.smooth(resolution).segments()

    def sample(self, spacing: float = DEFAULT_RESOLUTION) -> FloatArray:
        """Points around the circle, closed (the first point repeated last)."""
        p = self.smooth(spacing).points
        return np.vstack([p, p[:1]])

    def transformed(
        self, angle: float, offset: ArrayLike, resolution: float = DEFAULT_RESOLUTION
    ) -> Circle:
        """Rigidly moved copy."""
        c = rotate(np.asarray(self.center, dtype=np.float64), angle) + np.asarray(offset)
        return Circle(
            (float(c[0]), float(c[1])), self.radius, self.name, self.truth, self.phase + angle
        )


def wall(start: ArrayLike, end: ArrayLike, *, name: str = "", truth: bool = True) -> Polyline:
    """A straight wall from ``start`` to ``end`` (m)."""
    return Polyline(np.array([start, end], dtype=np.float64), False, name, truth)


def room(
    x_min: float, x_max: float, y_min: float, y_max: float, *, name: str = "room",
    truth: bool = False,
) -> Polyline:  # fmt: skip
    """A closed rectangular room. By default not part of the truth profile."""
    if not (x_max > x_min and y_max > y_min):
        raise ValueError("room needs x_min < x_max and y_min < y_max")
    pts = np.array([[x_min, y_min], [x_max, y_min], [x_max, y_max], [x_min, y_max]])
    return Polyline(pts, True, name, truth)
