"""Benchmark: thinning and friends on a 4000x4000 map against OpenCV's 3x3 filter2D.

Run with ./scripts/bench. The floor is ``cv2.filter2D`` computing the 3x3 neighbour count
of the same uint8 map (the core of any thinning), measured in the same run; scipy and
scikit-image figures are printed for context.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from benchtiming import best_of

from sonarproc import morphology as mo

pytestmark = pytest.mark.benchmark

SIZE = 4000


@pytest.fixture(scope="module")
def arc_like_map() -> np.ndarray:
    # Sparse, arc-like content: about 10 % of cells set, in clumps.
    rng = np.random.default_rng(0)
    m = rng.random((SIZE, SIZE)) < 0.04
    return np.asarray(mo.dilation(m) & (rng.random((SIZE, SIZE)) < 0.35))


def test_bench_thinning_vs_opencv(arc_like_map: np.ndarray) -> None:
    cv2 = pytest.importorskip("cv2")
    img = arc_like_map
    u8 = img.view(np.uint8)
    kernel = np.ones((3, 3), dtype=np.float32)
    kernel[1, 1] = 0.0

    def floor() -> object:
        return cv2.filter2D(u8, -1, kernel, borderType=cv2.BORDER_CONSTANT)

    np.testing.assert_array_equal(floor(), mo.neighbour_count(img))
    threads = cv2.getNumThreads()
    t_floor = best_of(floor, 7)
    cv2.setNumThreads(1)
    try:
        t_floor1 = best_of(floor, 7)
    finally:
        cv2.setNumThreads(threads)
    lines = [f"\nmorphology on {SIZE}x{SIZE} ({img.mean():.1%} set):"]
    lines.append(
        f"  floor cv2.filter2D 3x3 neighbour count: {t_floor * 1e3:.1f} ms "
        f"({threads} threads; {t_floor1 * 1e3:.1f} ms on 1 thread)"
    )
    cases: list[tuple[str, Callable[[], object]]] = [
        ("thinning(n=3)", lambda: mo.thinning(img, 3)),
        ("pruning", lambda: mo.pruning(img)),
        ("neighbour_count", lambda: mo.neighbour_count(img)),
        ("erosion", lambda: mo.erosion(img)),
        ("dilation", lambda: mo.dilation(img)),
        ("closing", lambda: mo.closing(img)),
    ]
    for name, fn in cases:
        t = best_of(fn, 7)
        target = "  (target <= 2x)" if name == "thinning(n=3)" else ""
        lines.append(f"  {name:16s} {t * 1e3:7.1f} ms   ours / floor = {t / t_floor:.2f}x{target}")
    print("\n".join(lines))


def test_bench_thinning_context(arc_like_map: np.ndarray) -> None:
    from scipy import ndimage
    from skimage.morphology import erosion as sk_erosion

    img = arc_like_map
    kernel = np.ones((3, 3), dtype=np.uint8)
    t_ours = best_of(lambda: mo.thinning(img, 3), 7)
    t_nd = best_of(lambda: ndimage.correlate(img.view(np.uint8), kernel, mode="constant"), 3)
    t_sk = best_of(lambda: sk_erosion(img, np.ones((3, 3), dtype=bool)), 3)
    print(
        f"\ncontext on {SIZE}x{SIZE}: thinning {t_ours * 1e3:.1f} ms; "
        f"scipy.ndimage.correlate {t_nd * 1e3:.1f} ms ({t_nd / t_ours:.1f}x ours); "
        f"skimage erosion {t_sk * 1e3:.1f} ms ({t_sk / t_ours:.1f}x ours)"
    )
