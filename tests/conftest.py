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


@pytest.fixture(autouse=True)
def private_port_locks(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every test's sonards keep their UUCP lock files in a directory of their own.

    ``/run/lock`` is shared by the whole machine, and a lock file outlives a sonard killed
    with SIGKILL (several tests do that). Its PID is then stale, and a lock file is taken
    over only when that PID is dead; with ``pid_max`` at 32768 the PID is soon reused by
    some other live process, and a later test given the same pty number was refused with
    "in use by PID ..." (or, in a script waiting for sonard's first command, waited for
    ever). A test that means two sonards to meet sets the directory itself.
    """
    monkeypatch.setenv("SONARD_LOCK_DIR", str(tmp_path_factory.mktemp("locks")))


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
