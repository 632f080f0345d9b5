"""Process helpers shared by the tests that start real emulators and daemons."""

from __future__ import annotations

import subprocess
import sys
from typing import Any

#: the command line entry point, as the installed ``sonarproc`` script calls it
SONARPROC = [sys.executable, "-c", "import sys; from sonarproc.cli import main; sys.exit(main())"]


def stop_process(proc: subprocess.Popen[Any], *, grace_s: float = 5.0) -> None:
    """Terminate ``proc`` (SIGTERM, then SIGKILL after ``grace_s``) and close its pipes."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(grace_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(grace_s)
    for pipe in (proc.stdin, proc.stdout, proc.stderr):
        if pipe is not None:
            pipe.close()


def sonarproc_in_child(args: list[str], timeout: float = 600.0) -> int:
    """Run ``sonarproc ARGS`` in a child process and return its exit code.

    dask's client leaves a thread pool running in the process that used it (its offload
    executor lives until exit). A test worker that keeps such a thread may no longer fork,
    which later tests in the same worker do; a child process takes the threads with it.
    """
    return subprocess.run([*SONARPROC, *args], timeout=timeout, check=False).returncode
