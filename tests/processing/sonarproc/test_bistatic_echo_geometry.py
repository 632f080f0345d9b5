"""A bistatic pair's echo off a plane, analytically: the first-echo model and the echo points.

The echo of a pair (transmitter T, receiver R) off a plane comes from the point where
the ellipse with foci T and R is tangent to the plane: the plane's crossing with the
segment from T to R's mirror image R', and the path ``|TP| + |PR|`` is ``|TR'|``.
``--auto``'s held-out loss and its echo refit use these (first_echo_path,
curve_echo_points).
"""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.methods.echo_model import curve_echo_points, first_echo, first_echo_path

#: Half beamwidth (rad) wide enough for every echo point below to be inside both beams.
WIDE = 0.6


def _plane(c0: float, slope: float) -> np.ndarray:
    """The line y = c0 + slope x, sampled every 1 mm over x = -3..3 m."""
    xs = np.linspace(-3.0, 3.0, 6001)
    return np.column_stack((xs, c0 + slope * xs))


def _mirror_echo(t: np.ndarray, r: np.ndarray, c0: float, slope: float) -> tuple[float, np.ndarray]:
    """The analytic path and echo point of pair (t, r) off the plane y = c0 + slope x."""
    n = np.array([-slope, 1.0]) / np.hypot(slope, 1.0)
    on = np.array([0.0, c0])
    mirror = r - 2.0 * np.dot(r - on, n) * n
    # the crossing of T -> R' with the plane: n . (T + u (R' - T) - on) = 0
    u = np.dot(on - t, n) / np.dot(mirror - t, n)
    return float(np.hypot(*(mirror - t))), t + u * (mirror - t)


@pytest.mark.parametrize(
    ("t", "r", "c0", "slope"),
    [
        ((-0.4, 0.0), (0.4, 0.0), 1.5, 0.0),  # symmetric pair under a level plane
        ((-0.4, 0.0), (0.4, 0.0), 1.5, 0.1),  # a plane tilted by 6 degrees
        ((0.2, 0.3), (1.1, -0.1), 2.0, -0.15),  # a pair at two heights, the other tilt
    ],
)
def test_a_pair_s_first_echo_off_a_plane_is_the_mirror_path(
    t: tuple[float, float], r: tuple[float, float], c0: float, slope: float
) -> None:
    tx, rx = np.array(t), np.array(r)
    plane = _plane(c0, slope)
    path, point = _mirror_echo(tx, rx, c0, slope)
    up = [np.pi / 2]
    got, at = first_echo([tx], up, [WIDE], [rx], up, [WIDE], plane)
    # the curve is sampled every millimetre: the path is stationary there, so its error
    # is second order in the sample spacing
    assert got[0] == pytest.approx(path, abs=1e-6)
    assert np.hypot(*(plane[at[0]] - point)) < 1.5e-3
    # the symmetric pair under a level plane: 2 sqrt(a^2 + D^2)
    if t == (-0.4, 0.0) and slope == 0.0:
        assert got[0] == pytest.approx(2.0 * np.hypot(0.4, 1.5), abs=1e-9)


def test_a_pair_s_echo_point_from_a_curve_off_the_plane_lies_on_the_plane() -> None:
    """The echo refit's echo point: the curve's specular point moved along its normal
    until its path is the measured one lands on the plane's tangent point."""
    tx, rx = np.array([-0.4, 0.0]), np.array([0.4, 0.0])
    path, point = _mirror_echo(tx, rx, 1.5, 0.0)
    near = _plane(1.47, 0.0)  # 3 cm short of the plane
    up = [np.pi / 2]
    rows, pts = curve_echo_points(
        [tx], up, [WIDE], [rx], up, [WIDE], [path], near, tol=0.05
    )  # fmt: skip
    assert rows.tolist() == [0]
    assert np.allclose(pts[0], point, atol=1e-3)
    # the same pair's path off the near curve is shorter than the measured one by about
    # twice the offset times the cosine of the half angle between the pair's rays
    short = first_echo_path([tx], up, [WIDE], [rx], up, [WIDE], near)[0]
    cos_half = 1.5 / np.hypot(0.4, 1.5)
    assert path - short == pytest.approx(2 * 0.03 * cos_half, abs=2e-4)
