"""The operations on the arc map: the paper's binary morphology and count-map votes.

Binary operations with the 3x3 square template (section 3.1 of the paper): erosion,
dilation, opening, closing, thinning(n) and pruning, in ``_binary``; operations on the
count map (how many arcs cross each cell), beyond the paper, in ``_counts``: ``vote:K``
and ``ridge``. A chain mixes both, written ``"closing,thinning:3"`` or
``"vote:auto,ridge"``:

>>> import numpy as np
>>> counts = np.zeros((5, 5), dtype=np.uint32)
>>> counts[2, :] = 3
>>> apply_chain(counts, "thinning:1").sum()
np.int64(5)
"""

from sonarproc.morphology._binary import (
    OPS,
    Op,
    apply_ops,
    box_count,
    closing,
    dilation,
    erosion,
    neighbour_count,
    opening,
    parse_ops,
    pruning,
    thinning,
)
from sonarproc.morphology._counts import (
    AUTO_FRACTION,
    CountOp,
    apply_chain,
    auto_vote_threshold,
    parse_chain,
    ridge,
    uses_counts,
    vote,
)

__all__ = [
    "AUTO_FRACTION",
    "OPS",
    "CountOp",
    "Op",
    "apply_chain",
    "apply_ops",
    "auto_vote_threshold",
    "box_count",
    "closing",
    "dilation",
    "erosion",
    "neighbour_count",
    "opening",
    "parse_chain",
    "parse_ops",
    "pruning",
    "ridge",
    "thinning",
    "uses_counts",
    "vote",
]
