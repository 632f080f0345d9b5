"""Run ``sonarproc run`` over many logs: chunks of logs to an engine, a report per log.

Each log's report is written into a temporary directory beside its final place and
renamed into place once complete, so a report directory is whole or absent, even when a
worker dies halfway. Workers write the reports themselves (on a cluster, ``out_dir`` must
be on a filesystem the workers share); only the summary rows come back.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sonarproc.batch.summary import error_row, summary_row
from sonarproc.engines import Engine, map_chunks
from sonarproc.params import RunParams
from sonarproc.run_modes import RunMode

__all__ = ["BatchOptions", "BatchResult", "chunk_size", "one_line", "report_names", "run_batch"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchOptions:
    """What every log of a batch is run with (``sonarproc run``'s options)."""

    params: RunParams = field(default_factory=RunParams)
    figures: tuple[str, ...] = ()
    sensors: str | None = None
    robot: str | None = None
    degrees: bool = False
    #: How the operations and fit are picked (:mod:`sonarproc.run_modes`), as ``run`` does.
    mode: RunMode = "given"


@dataclass(frozen=True)
class _Item:
    index: int
    log: str
    report: str


@dataclass
class BatchResult:
    """What :func:`run_batch` did: the summary rows in the order of the logs."""

    rows: list[dict[str, Any]]
    wall_s: float

    @property
    def failed(self) -> int:
        """Logs that gave no report."""
        return sum(1 for r in self.rows if r["status"] != "ok")


def report_names(logs: Sequence[str | Path]) -> list[str]:
    """A report directory name per log: its stem, made unique by ``-2``, ``-3``... in order.

    Examples
    --------
    >>> report_names(["a/scan.h5", "b/scan.h5", "run.bag", "scan-2.csv"])
    ['scan', 'scan-2', 'run', 'scan-2-2']
    """
    taken: set[str] = set()
    names: list[str] = []
    for p in logs:
        stem = Path(p).stem or Path(p).name or "log"
        name, k = stem, 1
        while name in taken:
            k += 1
            name = f"{stem}-{k}"
        taken.add(name)
        names.append(name)
    return names


def one_line(err: BaseException) -> str:
    """An error as one line: the file and the OS's reason, or the message.

    Errors that are not the project's own (a bug on one log) keep their type's name, so
    the summary says what to report.

    Examples
    --------
    >>> one_line(FileNotFoundError(2, "No such file or directory", "x.h5"))
    'x.h5: no such file or directory'
    >>> one_line(IndexError("index 3 is out of bounds\\nfor axis 0"))
    'IndexError: index 3 is out of bounds for axis 0'
    """
    from sonarlog import SonarLogError
    from sonarproc.errors import SonarprocError

    if isinstance(err, OSError) and err.strerror:
        text = err.strerror.lower()
        text = f"{err.filename}: {text}" if err.filename is not None else text
    elif isinstance(err, (SonarprocError, SonarLogError, ValueError)):
        text = str(err) or type(err).__name__
    else:
        text = f"{type(err).__name__}: {err}"
    return " ".join(text.split())


def _install(tmp: Path, final: Path) -> None:
    """Put the complete report ``tmp`` at ``final``, replacing an earlier one."""
    old = None
    if final.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-", dir=final.parent))
        os.replace(final, old / final.name)
    os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _quality_record(quality: Any) -> Any:
    """A run's quality as JSON-ready data: its ``to_json()``, a dataclass's fields, or as is."""
    if quality is None or isinstance(quality, dict):
        return quality
    if hasattr(quality, "to_json"):
        return quality.to_json()
    if dataclasses.is_dataclass(quality) and not isinstance(quality, type):
        return dataclasses.asdict(quality)
    return quality


def _run_one(item: _Item, out_dir: Path, opt: BatchOptions) -> dict[str, Any]:
    """Run one log into ``out_dir / item.report``; its summary row (an error row if not)."""
    from sonarproc.report import write_report
    from sonarproc.run_modes import run_log

    tmp = Path(tempfile.mkdtemp(prefix=f".{item.report}.partial-", dir=out_dir))
    try:
        # a sonarlog carries its mounts: --robot names those of the bags and CSVs only
        sonarlog = Path(item.log).suffix.lower() in (".h5", ".hdf5")
        robot = None if sonarlog else opt.robot
        read = {"sensors": opt.sensors, "robot": robot, "degrees": opt.degrees}
        result, record = run_log(item.log, opt.params, opt.mode, read=read)
        doc = write_report(result, tmp, auto=record, figures=opt.figures)
        if "quality" not in doc:
            doc["quality"] = _quality_record(getattr(result, "quality", None))
        _install(tmp, out_dir / item.report)
    except Exception as err:  # one log's failure is its row; the batch goes on
        log.debug("%s failed", item.log, exc_info=True)
        return error_row(item.index, item.log, one_line(err))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return summary_row(item.index, item.log, item.report, doc)


def run_chunk(task: tuple[list[_Item], str, BatchOptions]) -> list[dict[str, Any]]:
    """Run a chunk of logs (in a worker): their summary rows, in order."""
    items, out_dir, opt = task
    return [_run_one(item, Path(out_dir), opt) for item in items]


def chunk_size(logs: int, workers: int) -> int:
    """Logs per chunk: about four chunks per worker, so that a worker that drew short
    logs takes more while per-chunk hand-over stays a small part of a chunk's time.

    Examples
    --------
    >>> chunk_size(20, 2), chunk_size(3, 8), chunk_size(1000, 4)
    (3, 1, 63)
    """
    return max(1, math.ceil(logs / (4 * max(1, workers))))


def run_batch(
    logs: Sequence[str | Path],
    out_dir: Path,
    options: BatchOptions,
    *,
    engine: Engine | None = None,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> BatchResult:
    """Run every log and write its report directory under ``out_dir``.

    Parameters
    ----------
    logs : sequence of path-like
        Any log ``sonarproc run`` reads.
    out_dir : Path
        Created if missing; gets one directory per log (:func:`report_names`).
    options : BatchOptions
        The run options of every log.
    engine : Engine, optional
        Where the chunks run (default: local).
    workers : int
        Workers (local processes or a Dask ``LocalCluster``'s; 1 with the local engine:
        in this process).
    progress : callable, optional
        ``progress(done, total)`` after each chunk.

    Returns
    -------
    BatchResult
        One row per log, in the order given; the summary files are not written here
        (:func:`sonarproc.batch.write_summary`).
    """
    out_dir = Path(out_dir).absolute()  # workers may run elsewhere: no relative paths
    out_dir.mkdir(parents=True, exist_ok=True)
    items = [
        _Item(i, str(p), name)
        for i, (p, name) in enumerate(zip(logs, report_names(logs), strict=True))
    ]
    size = chunk_size(len(items), workers)
    chunks = [(items[s : s + size], str(out_dir), options) for s in range(0, len(items), size)]
    wall0 = time.perf_counter()
    finished = 0

    def advance(part: list[dict[str, Any]]) -> None:
        nonlocal finished
        finished += len(part)
        if progress is not None:
            progress(finished, len(items))

    advance([])
    parts = map_chunks(run_chunk, chunks, engine=engine or Engine(), workers=workers, done=advance)
    rows = [r for part in parts for r in part]
    return BatchResult(rows, time.perf_counter() - wall0)
