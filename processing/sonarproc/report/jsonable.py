"""Values made strict JSON: NaN and inf become null, numpy scalars Python numbers.

>>> import numpy as np
>>> to_jsonable({"a": np.float64("nan"), "b": [np.int64(2), 1.5]})
{'a': None, 'b': [2, 1.5]}
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["to_jsonable"]


def to_jsonable(v: Any) -> Any:
    """Make a value strict-JSON: NaN/inf become None, numpy scalars Python numbers."""
    if isinstance(v, dict):
        return {str(k): to_jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [to_jsonable(x) for x in v]
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v
