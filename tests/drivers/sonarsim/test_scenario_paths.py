"""Every scenario's robot stays in free space: its path never crosses a surface.

A path through a wall or a cabinet puts sensors inside a solid: the simulator then hears
the solid's inside, and a scorer counts the corners it sees from there as in view.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarsim import load_scenario

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = sorted((ROOT / "configs/scenarios").glob("*.yaml")) + sorted(
    (ROOT / "tests/data/scenarios").glob("*.yaml")
)


def _cross(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Whether segments a->b (rows) and c->d (columns) cross at interior points."""

    def side(o: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (
            q[..., 0] - o[..., 0]
        )

    a, b = a[:, None, :], b[:, None, :]
    c, d = c[None, :, :], d[None, :, :]
    return (side(c, d, a) * side(c, d, b) < 0.0) & (side(a, b, c) * side(a, b, d) < 0.0)


def test_crossing_is_detected() -> None:
    a, b = np.array([[0.0, 0.0], [0.0, 0.0]]), np.array([[2.0, 0.0], [0.5, 0.0]])
    c, d = np.array([[1.0, -1.0]]), np.array([[1.0, 1.0]])
    assert _cross(a, b, c, d)[:, 0].tolist() == [True, False]


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_path_stays_in_free_space(path: Path) -> None:
    sc = load_scenario(path)
    xy = np.column_stack((sc.poses.x, sc.poses.y))
    step = np.hypot(*np.diff(xy, axis=0).T) > 0.0
    a, b = xy[:-1][step], xy[1:][step]
    seg = sc.world.segments
    hits = np.zeros(a.shape[0], dtype=bool)
    for lo in range(0, a.shape[0], 512):  # bounded memory on long paths
        hits[lo : lo + 512] = _cross(a[lo : lo + 512], b[lo : lo + 512], seg.a, seg.b).any(axis=1)
    first = np.flatnonzero(hits)
    assert first.size == 0, f"the path crosses a surface between {a[first[0]]} and {b[first[0]]}"
