"""The tools' docstring examples run, and the tools stay outside the installed packages."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

import sonarmorph_tools

ROOT = Path(__file__).resolve().parents[2]


def _modules() -> list[str]:
    return sorted(
        [sonarmorph_tools.__name__]
        + [
            info.name
            for info in pkgutil.walk_packages(sonarmorph_tools.__path__, prefix="sonarmorph_tools.")
            if not info.name.rsplit(".", 1)[-1].startswith("__")
        ]
    )


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


def test_the_tools_are_not_packaged() -> None:
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    where = config["tool"]["setuptools"]["packages"]["find"]["where"]
    assert "tools" not in where and "." not in where
    assert Path(sonarmorph_tools.__file__).resolve().parent == ROOT / "tools" / "sonarmorph_tools"


def test_the_test_scenarios_are_found_from_the_checkout() -> None:
    assert sonarmorph_tools.TEST_SCENARIOS == ROOT / "tests" / "data" / "scenarios"
