"""Echo search: every specular echo per firing, in time order, with occlusion.

The two calls the rest of the project uses are :func:`echoes` (all echoes of explicit
transmitter/receiver pairs) and :func:`first_echo_path` (the first echo only, what the
Nomad reports). :func:`pair_echoes` is the same search over index pairs into one sensor
table, which the scenario simulator uses for "every pair bistatic" runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nomad200 import ring
from sonarsim.geometry import FloatArray
from sonarsim.images import image_order, sequences
from sonarsim.occlusion import blocked
from sonarsim.specular import Hits, IntArray, Sensors, Tables, first_order, sensor_tables
from sonarsim.world import World

HALF_BEAMWIDTH = ring.HALF_BEAMWIDTH
"""Polaroid 6500 half beam width (rad), the Nomad 200's."""
MIN_RANGE = ring.MIN_RANGE
"""Default minimum range (m), the Nomad 200's."""
MAX_RANGE = ring.MAX_RANGE
"""Default maximum range (m), the Nomad 200's."""

_TABLE_ELEMENTS = 3_000_000
_CHUNK_ELEMENTS = 4_000_000


@dataclass(frozen=True)
class Echoes:
    """Echoes sorted by firing, then by path length (i.e. in time order).

    Attributes
    ----------
    firing : ndarray of intp, shape (K,)
        Index of the firing (input pair) each echo belongs to.
    path : ndarray, shape (K,)
        Path length |TP| + |PR| (m), summed over all bounces.
    order : ndarray of int8, shape (K,)
        Number of bounces (1 = direct reflection).
    point : ndarray, shape (K, 2)
        The last reflection point (for ``order == 1`` the only one).
    first_point : ndarray, shape (K, 2)
        The first reflection point.
    surface : ndarray of intp, shape (K,)
        Index into ``world.surfaces`` of the last reflection.
    """

    firing: IntArray
    path: FloatArray
    order: NDArray[np.int8]
    point: FloatArray
    first_point: FloatArray
    surface: IntArray

    def __len__(self) -> int:
        return int(self.firing.size)

    def first(self) -> Echoes:
        """Only the first (shortest-path) echo of each firing."""
        if len(self) == 0:
            return self
        keep = np.ones(len(self), dtype=bool)
        keep[1:] = self.firing[1:] != self.firing[:-1]
        return self.take(np.flatnonzero(keep))

    def take(self, idx: IntArray) -> Echoes:
        """The rows ``idx``."""
        return Echoes(
            self.firing[idx], self.path[idx], self.order[idx], self.point[idx],
            self.first_point[idx], self.surface[idx],
        )  # fmt: skip


def _concat_hits(parts: list[Hits]) -> Hits:
    parts = [h for h in parts if h.pair.size]
    if not parts:
        return Hits.empty()
    if len(parts) == 1:
        return parts[0]
    return Hits(
        np.concatenate([h.pair for h in parts]),
        np.concatenate([h.path for h in parts]),
        np.concatenate([h.first for h in parts]),
        np.concatenate([h.last for h in parts]),
        np.concatenate([h.segment for h in parts]),
        np.concatenate([h.order for h in parts]),
        (),
    )


def _unoccluded(world: World, hits: Hits) -> Hits:
    if hits.pair.size == 0:
        return hits
    hit = np.zeros(hits.pair.size, dtype=bool)
    for q0, q1 in hits.legs:
        todo = ~hit
        if not todo.any():
            break
        hit[todo] = blocked(world.segments, q0[todo], q1[todo])
    keep = ~hit
    return Hits(
        hits.pair[keep], hits.path[keep], hits.first[keep], hits.last[keep],
        hits.segment[keep], hits.order[keep], (),
    )  # fmt: skip


def pair_echoes(
    world: World,
    sensors: Sensors,
    tx_index: ArrayLike,
    rx_index: ArrayLike,
    *,
    max_order: int = 1,
) -> Echoes:
    """All echoes for the pairs ``(tx_index[k], rx_index[k])`` of rows of ``sensors``.

    Parameters
    ----------
    world : World
        The surfaces.
    sensors : Sensors
        World poses and beam/range parameters of the sensors.
    tx_index, rx_index : array_like of int, shape (N,)
        Transmitter and receiver rows for each firing.
    max_order : int
        Highest number of bounces (>= 1). Orders above 1 use mirror images of flat
        segments.

    Returns
    -------
    Echoes
        ``firing`` indexes the pairs.
    """
    if max_order < 1:
        raise ValueError(f"max_order must be >= 1, got {max_order}")
    ti = np.asarray(tx_index, dtype=np.intp).ravel()
    ri = np.asarray(rx_index, dtype=np.intp).ravel()
    if ti.shape != ri.shape:
        raise ValueError("tx_index and rx_index must have the same length")
    segs = world.segments
    n_seg = len(segs)
    flat_idx = np.flatnonzero(segs.flat)
    seqs = [sequences(flat_idx, k) for k in range(2, max_order + 1)]
    parts: list[Hits] = []
    if n_seg and ti.size:
        global_tables: Tables | None = None
        if len(sensors) * n_seg <= _TABLE_ELEMENTS:
            global_tables = sensor_tables(segs, sensors)
        chunk = max(1, _CHUNK_ELEMENTS // n_seg)
        for c0 in range(0, ti.size, chunk):
            cti, cri = ti[c0 : c0 + chunk], ri[c0 : c0 + chunk]
            if global_tables is not None:
                tabs, sens, lti, lri = global_tables, sensors, cti, cri
            else:
                used, inv = np.unique(np.concatenate([cti, cri]), return_inverse=True)
                sens = sensors.take(used)
                tabs = sensor_tables(segs, sens)
                lti, lri = inv[: cti.size], inv[cti.size :]
            found = [first_order(segs, sens, tabs, lti, lri)]
            found += [image_order(segs, sens, tabs, lti, lri, s) for s in seqs]
            for h in found:
                h = _unoccluded(world, h)
                if h.pair.size:
                    parts.append(Hits(h.pair + c0, h.path, h.first, h.last, h.segment, h.order, ()))
    hits = _concat_hits(parts)
    order = np.lexsort((hits.path, hits.pair))
    if order.size > 1:
        # Rays that arrive together (e.g. a corner's two double-bounce orders) are one echo.
        same = (np.diff(hits.pair[order]) == 0) & (np.diff(hits.path[order]) < 1e-9)
        order = order[np.concatenate([[True], ~same])]
    return Echoes(
        hits.pair[order], hits.path[order], hits.order[order], hits.last[order],
        hits.first[order], segs.surface[hits.segment[order]] if n_seg else hits.segment,
    )  # fmt: skip


def _broadcast(
    tx_xy: ArrayLike, tx_heading: ArrayLike, rx_xy: ArrayLike, rx_heading: ArrayLike,
    half_beamwidth: ArrayLike, min_range: ArrayLike, max_range: ArrayLike,
) -> tuple[Sensors, IntArray, IntArray, int]:  # fmt: skip
    """One sensor table for N explicit firings, repeated sensors merged."""
    txy = np.atleast_2d(np.asarray(tx_xy, dtype=np.float64))
    rxy = np.atleast_2d(np.asarray(rx_xy, dtype=np.float64))
    if txy.shape[-1] != 2 or rxy.shape[-1] != 2 or txy.ndim != 2 or rxy.ndim != 2:
        raise ValueError("tx_xy and rx_xy must have shape (N, 2)")
    shapes = [(txy.shape[0],), (rxy.shape[0],)] + [
        np.shape(np.atleast_1d(v))
        for v in (tx_heading, rx_heading, half_beamwidth, min_range, max_range)
    ]
    n = int(np.broadcast_shapes(*shapes)[0])

    def vec(v: ArrayLike) -> FloatArray:
        a = np.asarray(v, dtype=np.float64)
        return np.broadcast_to(a.ravel() if a.ndim else a, (n,)).astype(np.float64)

    hbw, lo, hi = vec(half_beamwidth), vec(min_range), vec(max_range)
    rows = np.concatenate(
        [
            np.column_stack([np.broadcast_to(txy, (n, 2)), vec(tx_heading), hbw, lo, hi]),
            np.column_stack([np.broadcast_to(rxy, (n, 2)), vec(rx_heading), hbw, lo, hi]),
        ]
    )
    uniq, inv = np.unique(rows, axis=0, return_inverse=True)
    inv = inv.ravel().astype(np.intp)
    sensors = Sensors(uniq[:, :2], uniq[:, 2], uniq[:, 3], uniq[:, 4], uniq[:, 5])
    return sensors, inv[:n], inv[n:], n


def echoes(
    world: World,
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    *,
    half_beamwidth: ArrayLike = HALF_BEAMWIDTH,
    min_range: ArrayLike = MIN_RANGE,
    max_range: ArrayLike = MAX_RANGE,
    max_order: int = 1,
) -> Echoes:
    """All specular echoes of N firings, in time order, with occlusion.

    Parameters
    ----------
    world : World
        The surfaces.
    tx_xy, rx_xy : array_like, shape (N, 2) or (2,)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading : array_like, shape (N,) or scalar
        Lines of sight (rad, CCW from +x).
    half_beamwidth : float or array_like (N,)
        Half opening angle of both beams (rad).
    min_range, max_range : float or array_like (N,)
        Usable range of the receiver; an echo counts when half its path lies inside.
    max_order : int
        Highest number of bounces (mirror images of flat segments above 1).

    Returns
    -------
    Echoes
        ``firing`` indexes the N inputs; rows sorted by firing, then path.

    Examples
    --------
    >>> from sonarsim.surfaces import wall
    >>> w = World([wall((-1.0, 2.0), (1.0, 2.0))])
    >>> ev = echoes(w, [0.0, 0.0], np.pi / 2, [0.0, 0.0], np.pi / 2)
    >>> ev.firing.tolist(), ev.path.round(6).tolist()
    ([0], [4.0])
    """
    sensors, ti, ri, _ = _broadcast(
        tx_xy, tx_heading, rx_xy, rx_heading, half_beamwidth, min_range, max_range
    )
    return pair_echoes(world, sensors, ti, ri, max_order=max_order)


def first_echo_path(
    world: World,
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    *,
    half_beamwidth: ArrayLike = HALF_BEAMWIDTH,
    min_range: ArrayLike = MIN_RANGE,
    max_range: ArrayLike = MAX_RANGE,
    max_order: int = 2,
) -> FloatArray:
    """Path length of the first echo of each of N firings (NaN: no echo).

    Same parameters as :func:`echoes`; by default corners give their double bounce
    (``max_order=2``).

    Returns
    -------
    ndarray, shape (N,)
        ``|TP| + |PR|`` of the earliest echo in metres, NaN where nothing returns.

    Examples
    --------
    >>> from sonarsim.surfaces import wall
    >>> w = World([wall((-1.0, 2.0), (1.0, 2.0))])
    >>> first_echo_path(w, [[0.0, 0.0], [0.0, 0.0]], [np.pi / 2, 0.0],
    ...                 [[0.0, 0.0], [0.0, 0.0]], [np.pi / 2, 0.0]).round(6).tolist()
    [4.0, nan]
    """
    sensors, ti, ri, n = _broadcast(
        tx_xy, tx_heading, rx_xy, rx_heading, half_beamwidth, min_range, max_range
    )
    ev = pair_echoes(world, sensors, ti, ri, max_order=max_order).first()
    out = np.full(n, np.nan)
    out[ev.firing] = ev.path
    return out
