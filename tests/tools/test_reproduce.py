"""Tests for sonarmorph_tools.reproduce: the paper's values and the generated markdown."""

from __future__ import annotations

from sonarmorph_tools.reproduce import PAPER, TABLE1, TABLE2, Outcome, render_markdown


def _outcome(e: float | None, f_c: float, e1: float | None) -> Outcome:
    return Outcome(e, f_c, e1, None if e1 is None else e1 / 10, 0.01, 100, e1 is not None)


def test_paper_values_transcribed() -> None:
    assert PAPER["fig02"].ops == "thinning:3" and PAPER["fig02"].order == 9
    assert (PAPER["fig12"].e, PAPER["fig12"].E1_cm) == (0.245, 2.88)
    assert [p.ops for p in TABLE1[:8]] == [f"thinning:{n}" for n in range(1, 9)]
    assert TABLE1[2].E1_cm == 3.18 and TABLE2[8].E2 == 0.156
    assert all(p.order == 10 for p in TABLE2)


def test_markdown_tables_and_trend() -> None:
    rows = [(p, _outcome(0.5 - 0.05 * i, 1.0 - 0.1 * i, [9, 7, 5, 4, 6, 8, 20, 30, 9, 9][i]))
            for i, p in enumerate(TABLE1)]  # fmt: skip
    text = render_markdown(
        [("fig02", PAPER["fig02"], rows[2][1], "desc")], [("Table 1: x", rows)], cell=0.01
    )
    assert "| fig02 (Fig. 4) | `thinning:3` | 9 | 0.052 / 0.400 |" in text
    assert "## Table 1: x" in text and "- `fig02`: desc" in text
    assert "E1 is lowest at n = 4 (4.00 cm)" in text
    assert "f_c falls from 1.000 (n = 1) to 0.300 (n = 8)" in text
    assert "— / " in render_markdown(
        [("fig08a", PAPER["fig08a"], _outcome(None, 0.0, None), "")], [], cell=0.01
    )
