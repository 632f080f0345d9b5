"""The Examples sections of the public docstrings run, and print what they say."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

pytestmark = pytest.mark.slow

PACKAGES = ("nomad200", "sonarsim", "sonarlog", "sonard", "sonarproc")


def _modules() -> list[str]:
    names: list[str] = []
    for package in PACKAGES:
        pkg = importlib.import_module(package)
        names.append(package)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{package}."):
            if not info.name.rsplit(".", 1)[-1].startswith("__"):
                names.append(info.name)
    return sorted(names)


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


def _runnable_examples(name: str) -> int:
    """The examples :func:`doctest.testmod` attempts in module ``name`` (all it finds but
    those marked ``+SKIP``), counted without running them: the test above runs them."""
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder().find(module, name)
    return sum(not ex.options.get(doctest.SKIP, False) for t in tests for ex in t.examples)


def test_the_packages_document_by_example() -> None:
    attempted = sum(_runnable_examples(name) for name in _modules())
    assert attempted >= 100  # 137 when written: a drop means examples stopped being found
