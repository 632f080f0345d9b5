"""Reproduce the paper's reported numbers on the shipped scenarios: ``docs/reproduction.md``.

For each ``configs/scenarios/*.yaml``: simulate it (``sonarproc simulate``'s library
call), run the method with the paper's thinning ``n`` and polynomial order ``m`` for that
figure, and tabulate the paper's reported e, f_c, E1, E2 and t_CPU beside ours. Further
tables: our automatic method (:data:`AUTO`) on the same logs; the paper's Table 1 (the
Fig. 2 map) and Table 2 (the Fig. 18 surface); arcs drawn paper-style as samples at fixed
angular steps (:data:`ARC_STEPS_DEG`); own echoes against every pair for Figs. 10-12;
and the multi-surface scenes plus a sonard ring log with the default ``sonarproc run``.
The studies live in :mod:`sonarmorph_tools.reproduction`; this module is the command line.

Run ``./scripts/reproduce`` (or ``python -m sonarmorph_tools.reproduce``); ``--reports DIR``
also keeps each run's report directory.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sonarmorph_tools.reproduction import (
    ARC_STEPS_DEG,
    AUTO,
    PAPER,
    TABLE1,
    TABLE2,
    AutoOutcome,
    Outcome,
    PaperRow,
    SampledRow,
    outcome_line,
    render_markdown,
    reproduce,
)
from sonarproc.errors import SonarprocError
from sonarsim.shipped import shipped_dir

__all__ = [
    "ARC_STEPS_DEG",
    "AUTO",
    "PAPER",
    "TABLE1",
    "TABLE2",
    "AutoOutcome",
    "Outcome",
    "PaperRow",
    "SampledRow",
    "main",
    "outcome_line",
    "render_markdown",
    "reproduce",
]


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``python -m sonarmorph_tools.reproduce --out docs/reproduction.md``."""
    ap = argparse.ArgumentParser(prog="reproduce", description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", type=Path, default=shipped_dir("scenarios"))
    ap.add_argument("--out", type=Path, required=True, help="the markdown file to write")
    ap.add_argument("--cell", type=float, default=0.01)
    ap.add_argument("--reports", type=Path, default=None, help="keep report dirs here")
    ap.add_argument("--quiet", action="store_true", help="no progress, no per-scenario lines")
    ap.add_argument(
        "--only", action="append", default=None, metavar="NAME", help="this scenario only"
    )
    ap.add_argument(
        "--no-ring-log", action="store_true", help="leave the sonard ring log out (no sonard)"
    )
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="reproduce: %(message)s")
    unknown = sorted(set(args.only or ()) - {p.stem for p in args.scenarios.glob("*.yaml")})
    if unknown:
        print(f"reproduce: error: --only: no scenario {', '.join(unknown)} in {args.scenarios}",
              file=sys.stderr)  # fmt: skip
        return 2
    show = not args.quiet and sys.stdout.isatty()
    with _progress(show) as (bar, task):

        def started(name: str, k: int, total: int) -> None:
            if bar is not None:
                bar.update(task, completed=k, total=total, description=name)

        def finished(line: str) -> None:
            if args.quiet:
                return
            if bar is not None:
                bar.console.print(line)
            else:
                print(line, file=sys.stderr)

        try:
            text = reproduce(
                args.scenarios, cell=args.cell, reports=args.reports, progress=started,
                done=finished, only=args.only, ring=not args.no_ring_log,
            )  # fmt: skip
        except SonarprocError as err:
            print(f"reproduce: error: {err}", file=sys.stderr)
            return 1
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print(f"reproduce: wrote {args.out}", file=sys.stderr)
    return 0


@contextmanager
def _progress(show: bool) -> Iterator[tuple[Any, Any]]:
    """A rich progress bar on stderr over the scenarios, or ``(None, None)``."""
    if not show:
        yield None, None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    bar = Progress(
        TextColumn("{task.description:<12}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    )
    with bar:
        yield bar, bar.add_task("reproduce", total=None)


if __name__ == "__main__":
    sys.exit(main())
