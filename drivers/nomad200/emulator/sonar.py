"""The emulated Sensus 200 sonar ring: 16 Polaroid transducers fired one at a time.

Sonar ``i`` sits on the ring of :mod:`nomad200.ring` round the turret centre and looks
along ``turret + i * 22.5 deg``. One ranging module serves the ring, so each firing listens
until the next one starts. A reading is the FIRST echo heard in that window, in whole inches
from the transducer face (255: none). If the previous firing's pulse comes back late, into
this window, and earlier than the own echo, the reading is that crosstalk.

Echo paths come from a ``sonarsim`` world (:func:`sonarsim.first_echo_path`) or any
function with the same signature minus the world (see :data:`EchoFn`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nomad200 import ring

__all__ = [
    "HALF_BEAMWIDTH",
    "MAX_RANGE",
    "MIN_RANGE",
    "RING_RADIUS",
    "SPEED_OF_SOUND",
    "EchoFn",
    "FiringBatch",
    "echo_fn_for_world",
    "ring_geometry",
    "simulate_firings",
]

RING_RADIUS: Final = ring.RADIUS
SPEED_OF_SOUND: Final = 343.3
HALF_BEAMWIDTH: Final = ring.HALF_BEAMWIDTH
MIN_RANGE: Final = ring.MIN_RANGE
MAX_RANGE: Final = ring.MAX_RANGE
_INCH: Final = 0.0254

Array = NDArray[np.float64]
#: ``(tx_xy, tx_heading, rx_xy, rx_heading) -> path`` (m, NaN = no echo), vectorised
EchoFn = Callable[[Array, Array, Array, Array], Array]


def echo_fn_for_world(world: Any) -> EchoFn:
    """Wrap a sonarsim world as an :data:`EchoFn` with Polaroid beam parameters."""
    from sonarsim import first_echo_path  # deferred: only the emulator needs sonarsim

    def fn(tx_xy: Array, tx_h: Array, rx_xy: Array, rx_h: Array) -> Array:
        return np.asarray(
            first_echo_path(
                world,
                tx_xy,
                tx_h,
                rx_xy,
                rx_h,
                half_beamwidth=HALF_BEAMWIDTH,
                min_range=MIN_RANGE,
                max_range=MAX_RANGE,
            ),
            dtype=np.float64,
        )

    return fn


def ring_geometry(xy: Array, turret: Array, sonar: NDArray[np.int_]) -> tuple[Array, Array]:
    """World position and heading of transducers.

    Parameters
    ----------
    xy : (N, 2) array
        Robot (turret centre) positions in the world.
    turret : (N,) array
        Turret headings in the world (rad).
    sonar : (N,) int array
        Transducer ids.

    Returns
    -------
    pos : (N, 2) array
    heading : (N,) array
    """
    heading = turret + ring.HEADINGS[sonar]
    pos = xy + RING_RADIUS * np.column_stack((np.cos(heading), np.sin(heading)))
    return pos, heading


@dataclass
class FiringBatch:
    """Readings of consecutive firings (all arrays length N)."""

    raw: NDArray[np.int_]  #: inches, 255 = no echo
    tau: Array  #: time of the reported echo after firing (s), NaN if none
    crosstalk: NDArray[np.bool_]
    true_range: Array  #: own first-echo range from the transducer face (m), NaN if none


def simulate_firings(
    echo: EchoFn | None,
    t: Array,
    sonar: NDArray[np.int_],
    xy: Array,
    turret: Array,
    window: Array,
    prev: tuple[float, int, Array, float] | None,
) -> FiringBatch:
    """Readings for N consecutive firings (vectorised).

    Parameters
    ----------
    echo : EchoFn or None
        Path function; ``None`` = empty world (no echoes).
    t : (N,) array
        Firing times (s).
    sonar : (N,) int array
        Which transducer fired.
    xy, turret : (N, 2) and (N,) arrays
        TRUE robot position and turret heading in the world at each firing.
    window : (N,) array
        Listening time of each firing (until the next firing), s.
    prev : tuple or None
        ``(t, sonar, xy, turret)`` of the firing before ``t[0]``, for crosstalk.
    """
    n = len(t)
    if echo is None or n == 0:
        nan = np.full(n, np.nan)
        return FiringBatch(np.full(n, 255, dtype=np.int_), nan, np.zeros(n, bool), nan.copy())
    pos, head = ring_geometry(xy, turret, sonar)
    # previous firing of each firing: the one before it in the sequence
    if prev is not None:
        p_t = np.concatenate(([prev[0]], t[:-1]))
        p_s = np.concatenate(([prev[1]], sonar[:-1]))
        p_xy = np.vstack((prev[2][None, :], xy[:-1]))
        p_tu = np.concatenate(([prev[3]], turret[:-1]))
        has_prev = np.ones(n, bool)
    else:
        p_t, p_s, p_xy, p_tu = t - 1e9, sonar, xy, turret
        if n > 1:
            p_t = np.concatenate(([t[0] - 1e9], t[:-1]))
            p_s = np.concatenate(([sonar[0]], sonar[:-1]))
            p_xy = np.vstack((xy[:1], xy[:-1]))
            p_tu = np.concatenate(([turret[0]], turret[:-1]))
        has_prev = np.arange(n) > 0
    ppos, phead = ring_geometry(p_xy, p_tu, p_s)
    paths = echo(
        np.vstack((pos, ppos)),
        np.concatenate((head, phead)),
        np.vstack((pos, pos)),
        np.concatenate((head, head)),
    )
    own, cross = paths[:n], paths[n:]
    c = SPEED_OF_SOUND
    t_min = 2 * MIN_RANGE / c
    tau_own = own / c
    tau_x = cross / c - (t - p_t)
    ok_own = np.isfinite(tau_own) & (tau_own >= t_min) & (tau_own <= window)
    ok_x = has_prev & np.isfinite(tau_x) & (tau_x >= t_min) & (tau_x <= window)
    a = np.where(ok_own, tau_own, np.inf)
    b = np.where(ok_x, tau_x, np.inf)
    tau = np.minimum(a, b)
    xtalk = b < a
    inches = np.rint(tau * c / 2 / _INCH)
    good = np.isfinite(tau) & (inches <= 254)
    raw = np.where(good, inches, 255).astype(np.int_)
    return FiringBatch(raw, np.where(good, tau, np.nan), xtalk & good, own / 2)
