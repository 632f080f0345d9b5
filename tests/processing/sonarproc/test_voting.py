"""The count-map operations vote and ridge in the --ops chain (sonarproc.morphology)."""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.morphology import apply_ops, thinning
from sonarproc.morphology._counts import (
    CountOp,
    apply_chain,
    auto_vote_threshold,
    parse_chain,
    ridge,
    uses_counts,
    vote,
)


def test_parse_chain_mixes_paper_and_count_ops() -> None:
    chain = parse_chain(" Vote:3 , ridge:40, closing ,thinning:2,vote:AUTO,ridge")
    assert [str(op) for op in chain] == [
        "vote:3", "ridge:40", "closing", "thinning:2", "vote:auto", "ridge:50"
    ]  # fmt: skip
    assert chain[4] == CountOp("vote", None)
    assert parse_chain("") == [] and parse_chain("  ") == []
    assert uses_counts("closing,vote:2") and not uses_counts("closing,thinning:3")


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("vote", "vote needs K or auto"),
        ("vote:0", "K must be >= 1"),
        ("vote:x", "K must be an integer >= 1 or auto"),
        ("ridge:0", "P must be in 1..100"),
        ("ridge:101", "P must be in 1..100"),
        ("ridge:half", "P must be an integer percent"),
        ("thinning:9", "n must be in 1..8"),
        ("blur", "allowed: erosion, dilation, opening, closing, pruning, thinning:N, vote:K"),
    ],
)
def test_parse_chain_errors(spec: str, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(".", r"\.")):
        parse_chain(spec)


def test_vote_and_ridge_values() -> None:
    c = np.array([[0, 1, 5, 2], [3, 4, 5, 0], [6, 2, 1, 0]], dtype=np.uint16)
    m = c > 0
    assert vote(m, c, 3).astype(int).tolist() == [[0, 0, 1, 0], [1, 1, 1, 0], [1, 0, 0, 0]]
    # per column: max 6, 4, 5, 2 -> keep >= 3, 2, 2.5, 1
    assert ridge(m, c).astype(int).tolist() == [[0, 0, 1, 1], [1, 1, 1, 0], [1, 1, 0, 0]]
    assert ridge(m, c, 100).astype(int).tolist() == [[0, 0, 1, 1], [0, 1, 1, 0], [1, 0, 0, 0]]
    # only set cells of the mask compete: masking the 6 makes 3 the crest of column 0
    m2 = m.copy()
    m2[2, 0] = False
    assert ridge(m2, c, 100)[:, 0].tolist() == [False, True, False]
    with pytest.raises(ValueError, match="one shape"):
        vote(m, c[:, :2], 1)


def test_auto_vote_threshold_values() -> None:
    c = np.zeros((6, 10), dtype=np.uint16)
    c[3] = [40, 40, 40, 40, 40, 40, 40, 40, 40, 40]
    assert auto_vote_threshold(c) == 10  # ceil(0.25 * 40)
    c[3, :5] = 10  # q90 of [10]*5 + [40]*5 is 40
    assert auto_vote_threshold(c) == 10
    assert auto_vote_threshold(np.zeros((3, 3), dtype=np.uint16)) == 2
    assert auto_vote_threshold(np.ones((3, 3), dtype=np.uint16)) == 2  # never below 2
    with pytest.raises(ValueError, match="2-D"):
        auto_vote_threshold(np.ones(3))


def test_paper_chains_are_unchanged() -> None:
    rng = np.random.default_rng(7)
    counts = (rng.random((40, 50)) < 0.45) * rng.integers(1, 9, (40, 50))
    for spec in ("", "thinning:3", "closing,thinning:4", "erosion,pruning", "opening"):
        np.testing.assert_array_equal(apply_chain(counts, spec), apply_ops(counts > 0, spec))


def test_mixed_chain_applies_in_order() -> None:
    rng = np.random.default_rng(8)
    counts = (rng.random((30, 30)) < 0.6) * rng.integers(1, 6, (30, 30))
    want = thinning(vote(counts > 0, counts, 2), 1)
    np.testing.assert_array_equal(apply_chain(counts, "vote:2,pruning"), want)
    want2 = vote(thinning(counts > 0, 3), counts, 4)
    np.testing.assert_array_equal(apply_chain(counts, "thinning:3,vote:4"), want2)


def test_vote_auto_ridge_finds_the_surface_in_a_saturated_map() -> None:
    # a band 21 cells thick where every cell is crossed by 1-6 arcs (saturated binary
    # map) around a surface row crossed by 30-40 arcs: thinning keeps the band, the
    # count vote keeps exactly the surface
    rng = np.random.default_rng(3)
    ny, nx = 60, 80
    cols = np.arange(nx)
    surface = (30 + 8 * np.sin(cols / 12.0)).round().astype(int)
    counts = np.zeros((ny, nx), dtype=np.uint16)
    rows = np.arange(ny)[:, None]
    band = np.abs(rows - surface[None, :]) <= 10
    counts[band] = rng.integers(1, 7, int(band.sum()))
    counts[surface, cols] = rng.integers(30, 41, nx)
    assert apply_chain(counts, "thinning:6").sum() > 10 * nx
    kept = apply_chain(counts, "vote:auto,ridge")
    ix, iy = np.nonzero(kept.T)  # column by column
    assert ix.tolist() == cols.tolist() and iy.tolist() == surface.tolist()
