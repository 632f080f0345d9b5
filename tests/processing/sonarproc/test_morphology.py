"""Morphology against direct per-pixel reference implementations, borders included."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.typing import NDArray

from sonarproc.morphology import Op, apply_ops, parse_ops
from sonarproc.morphology import _binary as mo

Bool = NDArray[np.bool_]


# --- references: obviously correct, one pixel at a time --------------------------------


def ref_neighbours(img: Bool) -> NDArray[np.int64]:
    ny, nx = img.shape
    out = np.zeros((ny, nx), dtype=np.int64)
    for i in range(ny):
        for j in range(nx):
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    if (di or dj) and 0 <= i + di < ny and 0 <= j + dj < nx:
                        out[i, j] += bool(img[i + di, j + dj])
    return out


def ref_thinning(img: Bool, n: int) -> Bool:
    nb = ref_neighbours(img)
    out = np.zeros(img.shape, dtype=bool)
    for i in range(img.shape[0]):
        for j in range(img.shape[1]):
            out[i, j] = bool(img[i, j]) and nb[i, j] >= n
    return out


def ref_erosion(img: Bool) -> Bool:
    # The paper: a set pixel keeps its value when all pixels under the template are set.
    return ref_thinning(img, 8)


def ref_dilation(img: Bool) -> Bool:
    # The paper: all eight neighbours of every set pixel become set.
    ny, nx = img.shape
    out = np.zeros((ny, nx), dtype=bool)
    for i in range(ny):
        for j in range(nx):
            if img[i, j]:
                for di in (-1, 0, 1):
                    for dj in (-1, 0, 1):
                        if 0 <= i + di < ny and 0 <= j + dj < nx:
                            out[i + di, j + dj] = True
    return out


REFS = {
    "erosion": ref_erosion,
    "dilation": ref_dilation,
    "opening": lambda m: ref_dilation(ref_erosion(m)),
    "closing": lambda m: ref_erosion(ref_dilation(m)),
    "pruning": lambda m: ref_thinning(m, 1),
}


maps = arrays(
    np.bool_,
    st.tuples(st.integers(1, 17), st.integers(1, 17)),
    elements=st.booleans(),
)


@settings(max_examples=60, deadline=None)
@given(img=maps)
def test_neighbour_count_matches_reference(img: Bool) -> None:
    got = mo.neighbour_count(img)
    assert got.dtype == np.uint8
    np.testing.assert_array_equal(got, ref_neighbours(img))
    np.testing.assert_array_equal(mo.box_count(img), ref_neighbours(img) + img)


@settings(max_examples=40, deadline=None)
@given(img=maps, n=st.integers(1, 8))
def test_thinning_matches_reference(img: Bool, n: int) -> None:
    got = mo.thinning(img, n)
    assert got.dtype == np.bool_ and got.shape == img.shape
    np.testing.assert_array_equal(got, ref_thinning(img, n))


@pytest.mark.parametrize("name", sorted(REFS))
@settings(max_examples=25, deadline=None)
@given(img=maps)
def test_operations_match_reference(name: str, img: Bool) -> None:
    got = getattr(mo, name)(img)
    assert got.dtype == np.bool_ and got.shape == img.shape
    np.testing.assert_array_equal(got, REFS[name](img))


@pytest.mark.parametrize("name", [*sorted(REFS), "thinning:3", "neighbour_count"])
def test_borders_and_strips_on_larger_maps(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # Dense maps touching every border, with strips of several sizes (incl. 1 row).
    rng = np.random.default_rng(11)
    img = rng.random((23, 9)) < 0.7
    img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = True
    for strip in (1, 2, 5, 64):
        monkeypatch.setattr(mo, "_STRIP", strip)
        if name == "neighbour_count":
            np.testing.assert_array_equal(mo.neighbour_count(img), ref_neighbours(img))
        elif name.startswith("thinning"):
            np.testing.assert_array_equal(mo.thinning(img, 3), ref_thinning(img, 3))
        else:
            np.testing.assert_array_equal(getattr(mo, name)(img), REFS[name](img))


def test_full_map_at_borders() -> None:
    ones = np.ones((4, 5), dtype=bool)
    # Outside the map counts as 0: borders erode, corners have 3 neighbours.
    assert mo.erosion(ones).sum() == 2 * 3
    assert mo.thinning(ones, 4).sum() == 4 * 5 - 4
    assert mo.thinning(ones, 3).all()
    assert mo.dilation(ones).all()
    assert mo.neighbour_count(ones)[0, 0] == 3


def test_inputs_uint8_and_values_other_than_one() -> None:
    rng = np.random.default_rng(2)
    img = (rng.random((12, 13)) < 0.5).astype(np.uint8) * 255
    b = img != 0
    np.testing.assert_array_equal(mo.thinning(img, 2), ref_thinning(b, 2))
    np.testing.assert_array_equal(mo.dilation(img.astype(np.uint32)), ref_dilation(b))
    np.testing.assert_array_equal(mo.erosion(b[:, ::2]), ref_erosion(b[:, ::2]))  # strided
    assert mo.erosion(np.zeros((0, 3), dtype=bool)).shape == (0, 3)
    with pytest.raises(ValueError, match="2-D"):
        mo.erosion(np.zeros(5, dtype=bool))


@pytest.mark.parametrize("n", [0, 9, -1, 2.5, True, "3"])
def test_thinning_rejects_bad_n(n: object) -> None:
    with pytest.raises(ValueError, match="1 <= n <= 8"):
        mo.thinning(np.ones((3, 3), dtype=bool), n)  # type: ignore[arg-type]


def test_thinning_extremes_are_pruning_and_erosion() -> None:
    rng = np.random.default_rng(4)
    img = rng.random((30, 40)) < 0.6
    np.testing.assert_array_equal(mo.thinning(img, 1), mo.pruning(img))
    np.testing.assert_array_equal(mo.thinning(img, 8), mo.erosion(img))


def test_input_is_not_modified() -> None:
    img = np.eye(6, dtype=bool)
    before = img.copy()
    for name in REFS:
        getattr(mo, name)(img)
    mo.thinning(img, 2)
    apply_ops(img, "closing,thinning:3")
    np.testing.assert_array_equal(img, before)


def test_parse_ops() -> None:
    assert parse_ops("closing,thinning:3") == [Op("closing"), Op("thinning", 3)]
    assert parse_ops(" Opening , pruning,erosion,dilation ") == [
        Op("opening"),
        Op("pruning"),
        Op("erosion"),
        Op("dilation"),
    ]
    assert parse_ops("") == []
    assert str(Op("thinning", 2)) == "thinning:2"


@pytest.mark.parametrize(
    ("spec", "needle"),
    [
        ("closing,thining:3", "'thining:3'"),
        ("blur", "'blur'"),
        ("thinning", "needs n"),
        ("thinning:", "needs n"),
        ("thinning:x", "'x'"),
        ("thinning:9", "1..8"),
        ("thinning:0", "1..8"),
        ("closing:2", "takes no argument"),
        ("closing,,opening", "''"),
    ],
)
def test_parse_ops_errors_name_the_token(spec: str, needle: str) -> None:
    with pytest.raises(ValueError) as err:
        parse_ops(spec)
    msg = str(err.value)
    assert needle in msg
    assert "\n" not in msg
    if "unknown" in msg:
        assert "erosion" in msg and "thinning:N" in msg


@settings(max_examples=25, deadline=None)
@given(img=maps, n=st.integers(1, 8))
def test_chains_compose(img: Bool, n: int) -> None:
    got = apply_ops(img, f"closing,thinning:{n}")
    np.testing.assert_array_equal(got, ref_thinning(REFS["closing"](img), n))
    ops = [Op("dilation"), Op("thinning", n), Op("opening")]
    np.testing.assert_array_equal(
        apply_ops(img, ops), REFS["opening"](ref_thinning(ref_dilation(img), n))
    )
    np.testing.assert_array_equal(apply_ops(img, []), img)


def test_apply_ops_rejects_bad_op_objects() -> None:
    with pytest.raises(ValueError, match="unknown"):
        apply_ops(np.ones((2, 2), dtype=bool), [Op("blur")])
    with pytest.raises(ValueError, match="needs n"):
        apply_ops(np.ones((2, 2), dtype=bool), [Op("thinning")])
