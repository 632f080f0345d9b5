"""The command's allocator setting: large freed arrays are reused, not faulted in again."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from sonarproc.runtime import retain_freed_memory

GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"

# Page faults of ten 64 MB arrays allocated, touched and freed after a first one.
_FAULTS = """
import resource, sys, numpy as np
if sys.argv[1] == "keep":
    from sonarproc.runtime import retain_freed_memory
    assert retain_freed_memory()
a = np.ones(8 << 20); del a
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(10):
    a = np.ones(8 << 20); a.sum(); del a
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
"""


def _faults(mode: str) -> int:
    out = subprocess.run(
        [sys.executable, "-c", _FAULTS, mode], capture_output=True, text=True, check=True
    )
    return int(out.stdout)


@pytest.mark.skipif(not GLIBC, reason="mallopt is glibc's")
def test_freed_arrays_are_reused_without_page_faults() -> None:
    assert retain_freed_memory() is True
    default, kept = _faults("default"), _faults("keep")
    # by default each freed 64 MB block goes back to the kernel and faults in again (at
    # least 32 faults each, even in 2 MB pages)
    assert default >= 10 * 32
    assert kept < 32


def test_the_command_sets_it(monkeypatch: pytest.MonkeyPatch) -> None:
    import sonarproc.cli.entry as cli_main

    calls: list[bool] = []
    monkeypatch.setattr(cli_main, "retain_freed_memory", lambda: calls.append(True) or True)
    assert cli_main.main(["--version"]) == 0
    assert calls == [True]


# The console script on --version; an exit handler (run after the command) prints how many
# objects the collector is left to look at, and how many are frozen.
_FROZEN = """
import atexit, gc, sys
atexit.register(lambda: print(sum(gc.get_count()), gc.get_freeze_count() > 0))
from sonarproc.cli.entry import main, run_console
sys.argv = ["sonarproc", "--version"]
run_console() if {console} else sys.exit(main())
"""


@pytest.mark.parametrize("console", [True, False])
def test_the_console_script_leaves_the_collector_nothing_at_exit(console: bool) -> None:
    out = subprocess.run(
        [sys.executable, "-c", _FROZEN.format(console=console)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    young, frozen = out.stdout.split()[-2:]
    # the console script freezes the modules and the command's objects as it ends; a
    # host process calling main() keeps its collector as it is
    assert frozen == str(console)
    if console:
        assert int(young) < 100


# Modules loaded in loading_modules(), with or without the console script's switch: the
# collector inside the block, and the frozen count and the collector after it.
_LOADING = """
import gc, sys
from sonarproc import runtime
if sys.argv[1] == "console":
    runtime.freeze_modules()
before = gc.get_freeze_count()
with runtime.loading_modules():
    inside = gc.isenabled()
    import sonarproc.pipeline.surfacefit
print(inside, gc.get_freeze_count() > before, gc.isenabled())
"""


@pytest.mark.parametrize("mode", ["console", "host"])
def test_a_commands_modules_load_out_of_the_collectors_sight(mode: str) -> None:
    out = subprocess.run(
        [sys.executable, "-c", _LOADING, mode], capture_output=True, text=True, check=True
    )
    inside, frozen, after = out.stdout.split()
    # the console script loads them with the collector off and freezes them; a host
    # process calling the command keeps its collector as it is
    assert (inside, frozen) == (("False", "True") if mode == "console" else ("True", "False"))
    assert after == "True"
