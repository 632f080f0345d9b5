"""The robot's pose track and its interpolation at each reading's time.

Positions are interpolated linearly; the heading is interpolated on the circle (through
the shorter turn between two poses), so a robot turning through +-180 degrees does not
spin the wrong way round.

>>> track = PoseTrack.of([0.0, 1.0], [0.0, 1.0], [0.0, 0.0], np.radians([179.0, -179.0]))
>>> x, y, theta, inside = track.at(np.array([0.5, 2.0]))
>>> round(float(np.degrees(theta[0])), 6), inside.tolist()
(180.0, [True, False])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarlog.schema import POSE_DTYPE

__all__ = ["PoseTrack", "wrap_angle", "yaw_from_quaternion"]

FloatArray = npt.NDArray[np.float64]


def wrap_angle(a: npt.ArrayLike) -> FloatArray:
    """Angles wrapped to ``(-pi, pi]``."""
    w = np.asarray(a, dtype=np.float64)
    out = np.mod(w + np.pi, 2.0 * np.pi) - np.pi
    return np.asarray(np.where(out == -np.pi, np.pi, out), dtype=np.float64)


def yaw_from_quaternion(
    qx: npt.ArrayLike, qy: npt.ArrayLike, qz: npt.ArrayLike, qw: npt.ArrayLike
) -> FloatArray:
    """Heading (rotation about z, rad) of unit quaternions, vectorised.

    Examples
    --------
    >>> float(np.degrees(yaw_from_quaternion(0.0, 0.0, np.sin(0.25), np.cos(0.25))).round(6))
    28.64789
    """
    x, y, z, w = (np.asarray(v, dtype=np.float64) for v in (qx, qy, qz, qw))
    return np.asarray(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


@dataclass(frozen=True)
class PoseTrack:
    """Robot base poses in the world (odometry) frame, sorted by time, times unique.

    Attributes
    ----------
    t, x, y, theta : numpy.ndarray
        Seconds, metres, metres, radians.
    """

    t: FloatArray
    x: FloatArray
    y: FloatArray
    theta: FloatArray

    @classmethod
    def of(
        cls, t: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike, theta: npt.ArrayLike
    ) -> PoseTrack:
        """Build a track from samples in any order; of samples at one time the last wins."""
        tt, xx, yy, th = (np.asarray(v, dtype=np.float64).ravel() for v in (t, x, y, theta))
        good = np.isfinite(tt) & np.isfinite(xx) & np.isfinite(yy) & np.isfinite(th)
        tt, xx, yy, th = tt[good], xx[good], yy[good], th[good]
        order = np.argsort(tt, kind="stable")
        tt, xx, yy, th = tt[order], xx[order], yy[order], th[order]
        last = np.ones(tt.size, dtype=bool)
        last[:-1] = tt[1:] != tt[:-1]
        return cls(tt[last], xx[last], yy[last], th[last])

    def __len__(self) -> int:
        return int(self.t.size)

    def at(
        self, t: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
        """Interpolate the pose at times ``t``.

        Returns
        -------
        x, y, theta : numpy.ndarray
            The pose at each time (NaN outside the track's time span).
        inside : numpy.ndarray of bool
            Whether each time lies within ``[t[0], t[-1]]``.
        """
        q = np.asarray(t, dtype=np.float64)
        if self.t.size == 0:
            nan = np.full(q.shape, np.nan)
            return nan, nan.copy(), nan.copy(), np.zeros(q.shape, dtype=bool)
        inside = (q >= self.t[0]) & (q <= self.t[-1])
        # Unwrapping turns each step into the shorter turn, so linear interpolation of the
        # unwrapped heading goes round the circle the short way.
        unwrapped = np.unwrap(self.theta)
        x = np.interp(q, self.t, self.x)
        y = np.interp(q, self.t, self.y)
        theta = wrap_angle(np.interp(q, self.t, unwrapped))
        nan = np.where(inside, 0.0, np.nan)
        return x + nan, y + nan, theta + nan, inside

    def records(self) -> np.ndarray:
        """The track as :data:`sonarlog.POSE_DTYPE` rows (turret = heading)."""
        out = np.zeros(self.t.size, dtype=POSE_DTYPE)
        out["t"], out["x"], out["y"] = self.t, self.x, self.y
        out["theta"] = out["turret"] = self.theta
        return out
