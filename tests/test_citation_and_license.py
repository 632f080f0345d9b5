"""The repository says how to cite it and the paper, and carries the licence it declares."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def _citation() -> dict[str, object]:
    doc = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert isinstance(doc, dict)
    return doc


def test_citation_has_the_required_keys_of_cff_1_2() -> None:
    doc = _citation()
    assert doc["cff-version"] == "1.2.0"
    for key in ("message", "title", "authors"):
        assert doc[key], key
    assert doc["type"] == "software" and doc["license"] == "MIT"
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    version = re.search(r'^version = "([^"]+)"', pyproject, re.MULTILINE)
    assert version is not None and doc["version"] == version.group(1)


def test_citation_references_the_paper() -> None:
    (paper,) = _citation()["references"]
    assert paper["type"] == "article"
    assert [a["family-names"] for a in paper["authors"]] == ["Başkent", "Barshan"]
    assert paper["title"] == (
        "Surface Profile Determination from Multiple Sonar Data Using Morphological Processing"
    )
    assert paper["journal"] == "The International Journal of Robotics Research"
    assert (paper["year"], paper["volume"], str(paper["issue"])) == (1999, 18, "8")
    assert (paper["start"], paper["end"]) == (788, 808)
    assert paper["doi"] == "10.1177/02783649922066565"


def test_license_is_the_mit_licence_pyproject_declares() -> None:
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License\n")
    assert "Copyright (c) 2026 sonarmorph contributors" in text
    assert 'license = "MIT"' in (ROOT / "pyproject.toml").read_text(encoding="utf-8")
