"""Suite-wide settings: property tests draw the same examples on every run and machine."""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

# Seeded like every other random draw in the suite: a failure found once is found again,
# and a run never depends on an example database left by an earlier one.
settings.register_profile("repeatable", derandomize=True, database=None)
# CI (.ci/run): the same fixed examples, and the fuzz tests draw 300 per input kind
# instead of 100 (tests/support/fuzzing.py)
settings.register_profile("ci", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False, max_examples=1000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Run the tests marked ``slow`` first, each group in collection order.

    The suite hands whole test files to its xdist workers (``--dist=loadfile``, so a
    module's fixtures are built once), in collection order (``--no-loadscope-reorder``,
    pyproject.toml): a file comes at its first test, so the files holding slow tests go
    out first and the short ones fill in, and both workers finish together instead of one
    running a minute-long file alone at the end. Every worker sorts the same collection
    the same way (a stable sort), as xdist requires.
    """
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
