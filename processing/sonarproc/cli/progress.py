"""Progress for commands that can take more than a couple of seconds.

A rich progress bar on stderr while stdout is a terminal; nothing at all otherwise, so
pipes, logs and ``--json`` output stay clean. Commands hold a :class:`Steps` and call it
with ``(done, total)`` or advance it by one.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["Steps", "progress", "wanted"]


def wanted(quiet: bool = False) -> bool:
    """Whether to show progress: stdout is a terminal and the caller is not quiet."""
    return not quiet and sys.stdout.isatty()


class Steps:
    """A task on a rich progress bar, or nothing when the bar is off."""

    def __init__(self, bar: Any, task: Any) -> None:
        self._bar = bar
        self._task = task

    def __call__(self, done: int, total: int | None = None) -> None:
        """Set the count done (and the total, when it becomes known)."""
        if self._bar is not None:
            self._bar.update(self._task, completed=done, total=total)

    def advance(self, description: str | None = None) -> None:
        """One more step done; optionally say what comes next."""
        if self._bar is not None:
            kw = {} if description is None else {"description": description}
            self._bar.update(self._task, advance=1, **kw)

    def describe(self, description: str) -> None:
        """Say what is being done now."""
        if self._bar is not None:
            self._bar.update(self._task, description=description)


@contextmanager
def progress(
    description: str, total: int | None, *, enabled: bool | None = None
) -> Iterator[Steps]:
    """A transient progress bar on stderr for the ``with`` block (off unless :func:`wanted`)."""
    if not (wanted() if enabled is None else enabled):
        yield Steps(None, None)
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bar = Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
    )
    with bar:
        yield Steps(bar, bar.add_task(description, total=total))
