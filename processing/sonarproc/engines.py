"""Where many runs execute: in this process, in a local process pool, or on a Dask cluster.

``sonarproc sweep`` and ``sonarproc batch`` cut their work into *chunks* (several runs
each, so that the cost of handing a task to a worker is paid per chunk, not per run) and
give them to :func:`map_chunks` with an :class:`Engine`:

- ``local``: a :class:`concurrent.futures.ProcessPoolExecutor` whose workers live for
  the whole call and start with the pipeline already imported (forked from this process,
  or from a fork server; one worker, or one chunk: in this process, no pool at all);
- ``dask``: :mod:`dask.distributed`, a ``LocalCluster`` of single-threaded worker
  processes, or the scheduler at ``dask=ADDRESS`` (``tcp://host:8786``, a
  ``dask-jobqueue`` cluster's address...). Dask is an optional extra
  (``pip install 'sonarmorph[dask]'``).

Whatever the engine, the chunks' results come back in the order of the chunks, so a table
built from them does not depend on where or in which order the chunks ran.
"""

from __future__ import annotations

import importlib.util
import logging
import multiprocessing
import multiprocessing.context
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

from sonarproc.errors import ParameterError

__all__ = ["DASK_HINT", "ENGINES", "Engine", "map_chunks", "parse_engine", "runs_here"]

log = logging.getLogger(__name__)

T = TypeVar("T")
R = TypeVar("R")

#: The engine spellings, for messages.
ENGINES = "local, dask or dask=SCHEDULER_ADDRESS"
#: What to do when ``--engine dask`` is asked for without Dask installed.
DASK_HINT = "dask needs the optional extra: pip install 'sonarmorph[dask]'"
#: Modules a local worker imports once, before its first chunk.
PRELOAD = ("sonarproc.sweep", "sonarproc.batch", "sonarproc.pipeline", "sonarsim")


@dataclass(frozen=True)
class Engine:
    """An engine and, for Dask, the scheduler address (None: a ``LocalCluster``)."""

    kind: Literal["local", "dask"] = "local"
    address: str | None = None

    def describe(self, workers: int) -> str:
        """One phrase for a summary line, e.g. ``"2 local worker(s)"``.

        Examples
        --------
        >>> Engine().describe(2), Engine("dask", "tcp://h:8786").describe(2)
        ('2 local worker(s)', 'dask at tcp://h:8786')
        """
        if self.kind == "local":
            return f"{workers} local worker(s)"
        return f"dask at {self.address}" if self.address else f"dask, {workers} local worker(s)"


def parse_engine(text: str) -> Engine:
    """Parse ``local``, ``dask`` or ``dask=SCHEDULER_ADDRESS``.

    Raises
    ------
    ParameterError
        Another word, an empty address, or ``dask`` without Dask installed.

    Examples
    --------
    >>> parse_engine("local")
    Engine(kind='local', address=None)
    >>> parse_engine("dask=tcp://10.0.0.5:8786").address
    'tcp://10.0.0.5:8786'
    """
    kind, sep, address = text.strip().partition("=")
    kind = kind.strip().lower()
    if kind == "local" and not sep:
        return Engine("local")
    if kind != "dask" or (sep and not address.strip()):
        raise ParameterError("engine", f"bad value {text!r}; expected {ENGINES}")
    if importlib.util.find_spec("distributed") is None:
        raise ParameterError("engine", DASK_HINT)
    return Engine("dask", address.strip() or None)


def _local_context() -> multiprocessing.context.BaseContext:
    """How local workers start.

    On Linux, from a parent that runs no other thread: a fork, which inherits every module
    the parent has imported (no start-up import at all; a lone thread holds no lock a
    child could inherit locked). Otherwise from a fork server that has imported the
    pipeline once (no fork of a multi-threaded parent, such as one drawing a progress
    bar); plain spawn where there is neither.
    """
    methods = multiprocessing.get_all_start_methods()
    if sys.platform == "linux" and "fork" in methods and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(PRELOAD))
        return ctx
    return multiprocessing.get_context("spawn")


def _preload() -> None:
    """Import the pipeline in a worker before its first chunk (its start-up, not a run's)."""
    import importlib

    for name in PRELOAD:
        importlib.import_module(name)


def runs_here(engine: Engine, workers: int, chunks: int) -> bool:
    """Whether :func:`map_chunks` runs the chunks in this process (no pool to start):
    the local engine with one worker, or one chunk.

    Examples
    --------
    >>> runs_here(Engine(), 1, 8), runs_here(Engine(), 2, 1), runs_here(Engine(), 2, 8)
    (True, True, False)
    """
    return engine.kind == "local" and (workers <= 1 or chunks <= 1)


def map_chunks(
    fn: Callable[[T], R],
    chunks: Sequence[T],
    *,
    engine: Engine = Engine(),
    workers: int = 1,
    done: Callable[[R], None] | None = None,
) -> list[R]:
    """``[fn(c) for c in chunks]``, run by ``engine`` on ``workers`` workers.

    Parameters
    ----------
    fn : callable
        A module-level function (workers import it by name).
    chunks : sequence
        Its arguments, one task each (picklable).
    engine : Engine
        Where to run.
    workers : int
        Local processes (``local``) or ``LocalCluster`` workers (``dask`` without an
        address); ignored with a scheduler address (the cluster has its own).
    done : callable, optional
        Told each chunk's result as it arrives (in completion order), in this process.

    Returns
    -------
    list
        The results in the order of ``chunks``.

    Raises
    ------
    Exception
        The first exception a chunk raised (re-raised here; the other chunks are
        cancelled or left to finish).
    """
    if engine.kind == "dask":
        return _map_dask(fn, chunks, engine.address, workers, done)
    if runs_here(engine, workers, len(chunks)):
        out = []
        for c in chunks:
            out.append(fn(c))
            if done is not None:
                done(out[-1])
        return out
    results: dict[int, R] = {}
    with ProcessPoolExecutor(
        max_workers=min(workers, len(chunks)), mp_context=_local_context(), initializer=_preload
    ) as pool:
        futures = {pool.submit(fn, c): i for i, c in enumerate(chunks)}
        try:
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                if done is not None:
                    done(results[futures[fut]])
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    return [results[i] for i in range(len(chunks))]


def _map_dask(
    fn: Callable[[T], R],
    chunks: Sequence[T],
    address: str | None,
    workers: int,
    done: Callable[[R], None] | None,
) -> list[R]:
    """:func:`map_chunks` on Dask: a ``LocalCluster`` for this call, or ``address``."""
    try:
        from distributed import Client, LocalCluster
        from distributed import as_completed as dask_completed
    except ImportError:  # checked by parse_engine; an Engine may be built by hand
        raise ParameterError("engine", DASK_HINT) from None
    cluster: Any = None
    if address is None:
        cluster = LocalCluster(
            n_workers=max(1, workers),
            threads_per_worker=1,  # the pipeline holds the GIL: one run per process
            processes=True,
            dashboard_address=":0",  # any free port: several clusters may run at once
            silence_logs=logging.ERROR,
        )
    client = Client(cluster if cluster is not None else address)
    try:
        # pure=False: two equal chunks are still two tasks (a run's timing is its own)
        futures = client.map(fn, list(chunks), pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        results: dict[int, R] = {}
        for fut in dask_completed(futures):
            results[index[fut.key]] = fut.result()
            if done is not None:
                done(results[index[fut.key]])
        return [results[i] for i in range(len(chunks))]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
