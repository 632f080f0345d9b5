"""run's default on the held-out scenes: every kind meets its goal; the page is fresh."""

from __future__ import annotations

import re

import pytest

from sonarmorph_tools import REPO_ROOT
from sonarmorph_tools.default_heldout import GOALS_M, held_out_rows, render, scenes


def test_two_held_out_scenes_of_each_kind() -> None:
    kinds = [next(k for k in GOALS_M if s.stem.startswith(f"default-{k}")) for s in scenes()]
    assert sorted(kinds) == sorted(2 * list(GOALS_M))


@pytest.mark.slow
def test_default_meets_every_kinds_goal_and_the_page_says_so() -> None:
    rows = held_out_rows()
    assert len(rows) == 8
    missed = [(r.scene, r.default_e1_m) for r in rows if not r.meets_goal]
    assert not missed
    page = (REPO_ROOT / "docs" / "default-heldout.md").read_text(encoding="utf-8")
    # the table's numbers, not its wording: regenerate the page when they move
    numbers = re.compile(r"^\| (default-\S+) \| \S+ \| (\d+) \| ([\d.]+) \|", re.M)
    assert numbers.findall(page) == numbers.findall(render(rows))
