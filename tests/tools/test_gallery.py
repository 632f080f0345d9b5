"""Tests for sonarmorph_tools.gallery: docs/gallery.md from the cases' reports."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np

from sonarmorph_tools.gallery import main


def _case(cases: Path, name: str, used: int, e1: float) -> None:
    rep, cmp_ = cases / name / "report", cases / name / "compare"
    rep.mkdir(parents=True)
    cmp_.mkdir(parents=True)
    doc = {"counts": {"readings_used": used}, "metrics": {"e": 0.5, "f_c": 0.9, "E1_m": e1}}
    (rep / "report.json").write_text(json.dumps(doc))
    rgb = np.zeros((8, 10, 3))
    rgb[:, 5:] = 1.0  # left half black, right half white
    for fig in ("arcmap", "fit"):
        mpimg.imsave(rep / f"{fig}.png", rgb)
    mpimg.imsave(cmp_ / "compare.png", rgb)


def test_gallery_copies_the_figures_and_writes_their_captions(tmp_path: Path) -> None:
    cases, img = tmp_path / "cases", tmp_path / "docs" / "gallery"
    _case(cases, "demo", 65, 0.0241)
    _case(cases, "fig12", 10787, 0.0877)
    assert main([str(cases), str(img), "demo", "fig12"]) == 0
    text = (tmp_path / "docs" / "gallery.md").read_text()
    assert text.startswith("# Gallery\n")
    assert "## Demo\n\nThe demo (`./scripts/demo`)" in text
    assert "## Scenario `fig12`\n\n`sonarproc simulate fig12`, then" in text
    assert "Run: 65 used, e 0.500, f_c 0.900, E1 2.41 cm." in text
    assert "Run: 10787 used, e 0.500, f_c 0.900, E1 8.77 cm." in text
    assert "![fig12: processed map, true surface and fit](gallery/fig12-fit.png)" in text
    assert sorted(p.name for p in img.iterdir()) == [
        "demo-arcmap.png", "demo-compare.png", "demo-fit.png",
        "fig12-arcmap.png", "fig12-compare.png", "fig12-fit.png",
    ]  # fmt: skip
    small = mpimg.imread(img / "fig12-compare.png")
    assert small.shape[:2] == (4, 5)  # 2 x 2 means of the 8 x 10 grid
    assert np.allclose(small[:, :2, :3], 0.0) and np.allclose(small[:, 3:, :3], 1.0)
    assert np.allclose(small[:, 2, :3], 0.5, atol=0.01)  # the column straddling the edge
