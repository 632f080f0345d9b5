"""Parameter sweeps: a grid of run parameters (and of noise and seeds on scenarios) run
in parallel locally or in shards over a cluster, and the shards merged into one table.

``grid`` parses the grid syntax and shards it; ``runner`` runs combinations; ``merge``
joins shard outputs and checks for missing or repeated combinations.
"""

from sonarproc.sweep.grid import (
    KEYS,
    Combination,
    GridSyntaxError,
    combinations,
    parse_grid,
    parse_shard,
    shard_indices,
)
from sonarproc.sweep.merge import MergeResult, best_rows, merge_shards
from sonarproc.sweep.runner import (
    COLUMNS,
    SweepResult,
    run_sweep,
    shard_stem,
    write_sweep,
    write_table,
)

__all__ = [
    "COLUMNS",
    "KEYS",
    "Combination",
    "GridSyntaxError",
    "MergeResult",
    "SweepResult",
    "best_rows",
    "combinations",
    "merge_shards",
    "parse_grid",
    "parse_shard",
    "run_sweep",
    "shard_indices",
    "shard_stem",
    "write_sweep",
    "write_table",
]
