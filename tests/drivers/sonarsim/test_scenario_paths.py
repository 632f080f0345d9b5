"""Every scenario's robot stays in free space: its path never crosses a surface.

A path through a wall or a cabinet puts sensors inside a solid: the simulator then hears
the solid's inside, and a scorer counts the corners it sees from there as in view.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarproc.surfaces.echoes.occlusion import segment_crossings
from sonarsim import load_scenario

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = sorted((ROOT / "configs/scenarios").glob("*.yaml")) + sorted(
    (ROOT / "tests/data/scenarios").glob("*.yaml")
)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_path_stays_in_free_space(path: Path) -> None:
    sc = load_scenario(path)
    xy = np.column_stack((sc.poses.x, sc.poses.y))
    step = np.hypot(*np.diff(xy, axis=0).T) > 0.0
    a, b = xy[:-1][step], xy[1:][step]
    seg = sc.world.segments
    rows = np.concatenate(
        [lo + segment_crossings(a[lo : lo + 512], b[lo : lo + 512], seg.a, seg.b)[0]
         for lo in range(0, a.shape[0], 512)]  # bounded memory on long paths
        or [np.zeros(0, dtype=np.intp)]
    )  # fmt: skip
    assert rows.size == 0, f"the path crosses a surface between {a[rows[0]]} and {b[rows[0]]}"
