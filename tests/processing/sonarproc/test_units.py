"""Lengths a person reads: one formatter, and never a huge number shown as a length."""

from __future__ import annotations

import math

import pytest

from sonarproc.report.auto_record import auto_record_html
from sonarproc.report.units import MAX_LENGTH_M, length_cm, metric


@pytest.mark.parametrize(
    ("metres", "text"),
    [
        (0.0288, "2.88 cm"),
        (0.025, "2.50 cm"),
        (MAX_LENGTH_M, "1.00e+05 cm"),
        (1.31e8, "unbounded"),
        (-1.31e8, "unbounded"),
        (math.inf, "unbounded"),
        (math.nan, "unbounded"),
        (None, "—"),
    ],
)
def test_length_cm(metres: float | None, text: str) -> None:
    assert length_cm(metres) == text


def test_metrics_by_key_use_the_same_rule() -> None:
    assert metric("E1_m", 1.31e8) == "unbounded"
    assert metric("precision_m", 0.00598) == "0.598 cm"


def test_auto_record_residuals_go_through_length_cm() -> None:
    rec = {
        "criterion": "held-out", "choice": "a", "fit_short": "poly m=9", "residual_m": 1.31e8,
        "runners_up": [{"name": "b", "fit_short": "spline", "residual_m": 0.0123}],
    }  # fmt: skip
    page = auto_record_html(rec)
    assert "held-out residual unbounded." in page
    assert "<td>1.23 cm</td>" in page and "e+" not in page
