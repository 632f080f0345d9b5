"""The robot's pose in any fixed frame of a bag's tf tree (``map -> odom -> base_link``).

A laser SLAM publishes its correction as a transform ``map -> odom`` beside the
odometry's ``odom -> base_link``; the robot's pose in ``map`` is their composition. The
tree is read from the bag's dynamic (``/tf``) and static (``/tf_static``) transforms:
each frame has one parent. :func:`chain_track` walks from the robot's base frame up to
the fixed frame and composes the links at the times of the chain's most frequent
dynamic link (the odometry's, usually): each dynamic link interpolated there (position
linearly, heading on the circle), each static link constant. Only times inside every
dynamic link's span are kept (where the whole chain is known).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from sonarlog.sources.errors import SourceError
from sonarlog.sources.poses import PoseTrack, wrap_angle, yaw_from_quaternion

__all__ = ["TfRow", "chain_frames", "chain_track"]

FloatArray = npt.NDArray[np.float64]

#: One dynamic transform: parent, child, time (s), x, y (m), rotation quaternion.
TfRow = tuple[str, str, float, float, float, tuple[float, float, float, float]]
#: A static link: the child's parent and its 2-D pose there (x, y, yaw).
StaticLink = tuple[str, float, float, float]


def _dynamic_parents(rows: Sequence[TfRow]) -> dict[str, tuple[str, int]]:
    """Each child frame's parent in the dynamic tf (the most frequent, if several)."""
    counts: dict[tuple[str, str], int] = {}
    for parent, child, *_ in rows:
        counts[(parent, child)] = counts.get((parent, child), 0) + 1
    out: dict[str, tuple[str, int]] = {}
    for (parent, child), n in counts.items():
        if child not in out or n > out[child][1]:
            out[child] = (parent, n)
    return out


def chain_frames(
    rows: Sequence[TfRow], static: dict[str, StaticLink], fixed: str, base: str
) -> list[tuple[str, str, bool]]:
    """The links ``(parent, child, dynamic)`` from ``base`` up to ``fixed``, base first.

    Raises
    ------
    SourceError
        No chain of transforms joins ``base`` to ``fixed`` (the message lists the frames).

    Examples
    --------
    >>> rows = [("map", "odom", 0.0, 0, 0, (0, 0, 0, 1)), ("odom", "base", 0.0, 0, 0, (0, 0, 0, 1))]
    >>> chain_frames(rows, {"sonar": ("base", 0.1, 0.0, 0.0)}, "map", "base")
    [('odom', 'base', True), ('map', 'odom', True)]
    """
    dynamic = _dynamic_parents(rows)
    links: list[tuple[str, str, bool]] = []
    node, seen = base, {base}
    while node != fixed:
        if node in dynamic:
            parent, dyn = dynamic[node][0], True
        elif node in static:
            parent, dyn = static[node][0], False
        else:
            frames = sorted({f for p, c, *_ in rows for f in (p, c)} | set(static)
                            | {s[0] for s in static.values()})  # fmt: skip
            raise SourceError(
                f"no tf chain from {fixed} to {base} (it stops at {node}; frames in the bag: "
                f"{', '.join(frames) or 'none'})"
            )
        if parent in seen:
            raise SourceError(f"the tf tree has a loop at frame {parent}")
        links.append((parent, node, dyn))
        seen.add(parent)
        node = parent
    return links


def _link_series(rows: Sequence[TfRow], parent: str, child: str) -> tuple[FloatArray, ...]:
    """A dynamic link's times (sorted, unique), x, y and unwrapped yaw."""
    mine = [r for r in rows if r[0] == parent and r[1] == child]
    t = np.array([r[2] for r in mine], dtype=np.float64)
    q = np.array([r[5] for r in mine], dtype=np.float64).reshape(-1, 4)
    yaw = yaw_from_quaternion(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
    x = np.array([r[3] for r in mine], dtype=np.float64)
    y = np.array([r[4] for r in mine], dtype=np.float64)
    order = np.argsort(t, kind="stable")
    t, x, y, yaw = t[order], x[order], y[order], yaw[order]
    last = np.r_[t[1:] != t[:-1], True]  # of equal stamps, the last published wins
    return t[last], x[last], y[last], np.unwrap(yaw[last])


def chain_track(
    rows: Sequence[TfRow], static: dict[str, StaticLink], fixed: str, base: str
) -> PoseTrack:
    """The pose of ``base`` in ``fixed`` over time, composed along the tf chain.

    Parameters
    ----------
    rows : sequence of TfRow
        Every dynamic transform of the bag.
    static : dict
        Static links: child frame -> (parent, x, y, yaw).
    fixed, base : str
        The fixed frame (``map``) and the robot's base frame (``base_link``).

    Raises
    ------
    SourceError
        No chain joins the frames, or the chain has no dynamic link, or its dynamic links
        never overlap in time.
    """
    links = chain_frames(rows, static, fixed, base)
    dynamic = {(p, c): _link_series(rows, p, c) for p, c, d in links if d}
    if not dynamic:
        raise SourceError(f"the tf chain from {fixed} to {base} is all static: no motion")
    clock = max(dynamic.values(), key=lambda s: s[0].size)[0]
    lo = max(float(s[0][0]) for s in dynamic.values())
    hi = min(float(s[0][-1]) for s in dynamic.values())
    t = clock[(clock >= lo) & (clock <= hi)]
    if t.size == 0:
        raise SourceError(
            f"the tf chain from {fixed} to {base}: its transforms never overlap in time"
        )
    x, y, yaw = np.zeros(t.size), np.zeros(t.size), np.zeros(t.size)
    for parent, child, dyn in reversed(links):  # from the fixed frame down to the base
        if dyn:
            st, sx, sy, syaw = dynamic[(parent, child)]
            lx, ly, lyaw = np.interp(t, st, sx), np.interp(t, st, sy), np.interp(t, st, syaw)
        else:
            _, px, py, pyaw = static[child]
            lx, ly, lyaw = np.full(t.size, px), np.full(t.size, py), np.full(t.size, pyaw)
        c, s = np.cos(yaw), np.sin(yaw)
        x, y, yaw = x + c * lx - s * ly, y + s * lx + c * ly, yaw + lyaw
    return PoseTrack.of(t, x, y, wrap_angle(yaw))
