"""Many logs at once: ``sonarproc run`` over a list of logs, one report each, one summary.

:func:`run_batch` cuts the logs into chunks and hands them to an engine
(:mod:`sonarproc.engines`: a local process pool or Dask); each log gets its own report
directory, written whole or not at all, and a row of the summary table
(:mod:`sonarproc.batch.summary`). A log that cannot be processed is an error row with a
one-line reason; the other logs go on.
"""

from sonarproc.batch.runner import BatchOptions, BatchResult, report_names, run_batch
from sonarproc.batch.summary import SUMMARY_COLUMNS, summary_row, write_summary

__all__ = [
    "SUMMARY_COLUMNS",
    "BatchOptions",
    "BatchResult",
    "report_names",
    "run_batch",
    "summary_row",
    "write_summary",
]
