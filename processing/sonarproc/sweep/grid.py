"""The grid of a parameter sweep: its syntax, its combinations and their shards.

See :mod:`sonarproc.sweep` for the grid spec (``KEY=VALUES;...``). Combinations are
numbered in a fixed order, inputs outermost, then the keys in the order the spec names
them (the last varying fastest), so that shard ``I/N`` (every N-th combination starting at
I) covers the grid together with the other shards of the same N on any machine.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.errors import ParameterError
from sonarproc.params import RunParams

__all__ = [
    "DATA_KEYS",
    "KEYS",
    "SYNTAX",
    "Combination",
    "GridSyntaxError",
    "combination_params",
    "combinations",
    "is_scenario_path",
    "parse_grid",
    "parse_shard",
    "shard_indices",
]

SYNTAX = (
    "KEY=V1|V2|A..B|LO..HI@N|LO..HI@logN[;KEY=...] with KEY in "
    "ops, order, cell, fit, robust, span, smooth, drop_crosstalk, arc_step, sigma, seed"
)

#: Parameter keys and the kind of their values.
KEYS: dict[str, str] = {
    "ops": "ops",
    "order": "order",
    "cell": "float",
    "fit": "choice:poly,spline,polar,auto",
    "robust": "choice:none,huber",
    "span": "choice:truth,points",
    "smooth": "float",
    "drop_crosstalk": "bool",
    "arc_step": "float",
    "sigma": "float",
    "seed": "int",
}
#: The fit where the grid names none: ``sonarproc run --paper``'s (a one-curve map gets the
#: paper's polynomial, a room its surfaces). A sweep measures what its knobs do, so no row
#: chooses its own knobs as a plain ``run`` does (:mod:`sonarproc.run_modes`).
RUN_DEFAULT_FIT = "auto"
#: Keys that change the data (simulation) rather than the processing.
DATA_KEYS = ("sigma", "seed")
_RANGE = re.compile(r"^(-?[0-9.eE+-]+?)\.\.(-?[0-9.eE+-]+?)(?:@(log)?([0-9]+))?$")
_INT_RANGE = re.compile(r"^(.*?)(-?[0-9]+)\.\.(-?[0-9]+)$")


class GridSyntaxError(ParameterError):
    """A bad sweep ``grid`` (or ``shard``) spec; the message names the token and the syntax."""


def _bad(token: str, why: str) -> GridSyntaxError:
    return GridSyntaxError("grid", f"bad token {token!r}: {why}; syntax: {SYNTAX}")


def _numbers(token: str, kind: str) -> list[Any]:
    """Expand one alternative of a numeric key: a number or a range."""
    m = _RANGE.match(token)
    if m is None:
        try:
            return [int(token)] if kind == "int" else [float(token)]
        except ValueError:
            raise _bad(token, f"not a{'n integer' if kind == 'int' else ' number'}") from None
    lo_s, hi_s, log_, count_s = m.groups()
    if count_s is None:
        try:
            lo, hi = int(lo_s), int(hi_s)
        except ValueError:
            raise _bad(token, "A..B needs integers (use LO..HI@N for numbers)") from None
        if hi < lo:
            raise _bad(token, "empty range (B < A)")
        values: list[Any] = list(range(lo, hi + 1))
        return values if kind == "int" else [float(v) for v in values]
    if kind == "int":
        raise _bad(token, "this key takes integers: use A..B")
    try:
        lo_f, hi_f = float(lo_s), float(hi_s)
    except ValueError:
        raise _bad(token, "range ends must be numbers") from None
    count = int(count_s)
    if count < 1:
        raise _bad(token, "the count after @ must be >= 1")
    if log_:
        if not (lo_f > 0 and hi_f > 0):
            raise _bad(token, "a log range needs LO > 0 and HI > 0")
        arr = np.geomspace(lo_f, hi_f, count)
    else:
        arr = np.linspace(lo_f, hi_f, count)
    return [float(f"{v:.6g}") for v in arr]


def _ops_values(token: str) -> list[str]:
    """Expand one ``ops`` alternative (a chain) with integer ranges inside its steps."""
    from sonarproc.morphology import parse_chain

    steps: list[list[str]] = []
    for step in token.split(","):
        step = step.strip()
        m = _INT_RANGE.match(step)
        if m is None:
            steps.append([step])
            continue
        head, lo, hi = m.group(1), int(m.group(2)), int(m.group(3))
        if hi < lo:
            raise _bad(token, "empty range (B < A)")
        steps.append([f"{head}{k}" for k in range(lo, hi + 1)])
    chains = [",".join(c) for c in itertools.product(*steps)]
    for chain in chains:
        try:
            parse_chain(chain)
        except ValueError as err:
            raise _bad(token, str(err)) from None
    return chains


def _expand(key: str, alternatives: list[str]) -> list[Any]:
    kind = KEYS[key]
    out: list[Any] = []
    for alt in alternatives:
        if kind == "ops":
            out.extend(_ops_values(alt))
        elif kind == "order":
            out.extend(["auto"] if alt.lower() == "auto" else _numbers(alt, "int"))
        elif kind in ("int", "float"):
            out.extend(_numbers(alt, kind))
        elif kind == "bool":
            low = alt.lower()
            if low not in ("true", "false", "1", "0", "yes", "no"):
                raise _bad(alt, "expected true or false")
            out.append(low in ("true", "1", "yes"))
        else:
            allowed = kind.split(":", 1)[1].split(",")
            if alt.lower() not in allowed:
                raise _bad(alt, f"expected one of {', '.join(allowed)}")
            out.append(alt.lower())
    for v in out:  # value checks: the same rules as sonarproc run
        _check_value(key, v)
    return out


def _check_value(key: str, v: Any) -> None:
    if key == "sigma":
        if not (math.isfinite(v) and 0 <= v <= 1):
            raise _bad(f"{key}={v}", "sigma must be between 0 and 1 m")
        return
    if key == "seed":
        if v < 0:
            raise _bad(f"{key}={v}", "seed must be >= 0")
        return
    try:
        combination_params({key: v})
    except ValueError as err:
        raise _bad(f"{key}={v}", str(err)) from None


def parse_grid(spec: str) -> dict[str, list[Any]]:
    """Parse a grid spec into ``{key: [values...]}`` in the order the spec names the keys.

    Parameters
    ----------
    spec : str
        ``KEY=VALUES[;KEY=VALUES...]`` (see the module docstring).

    Returns
    -------
    dict

    Raises
    ------
    GridSyntaxError
        One line naming the bad token and giving the syntax.

    Examples
    --------
    >>> g = parse_grid("ops=thinning:1..3;order=4,6|8;cell=0.01..0.03@3")
    >>> g["ops"], g["order"], g["cell"]
    (['thinning:1', 'thinning:2', 'thinning:3'], [4, 6, 8], [0.01, 0.02, 0.03])
    """
    grid: dict[str, list[Any]] = {}
    parts = [p.strip() for p in spec.split(";") if p.strip()]
    if not parts:
        raise _bad(spec, "empty grid")
    for part in parts:
        key, sep, values = part.partition("=")
        key = key.strip().lower().replace("-", "_")
        if not sep or not values.strip():
            raise _bad(part, "expected KEY=VALUES")
        if key not in KEYS:
            raise _bad(part, f"unknown key {key!r}")
        if key in grid:
            raise _bad(part, f"key {key!r} given twice")
        seps = r"\|" if key == "ops" else r"[|,]"
        alternatives = [a.strip() for a in re.split(seps, values)]
        if any(not a for a in alternatives):
            raise _bad(part, "empty value")
        expanded = _expand(key, alternatives)
        if len(set(map(str, expanded))) != len(expanded):
            raise _bad(part, "a value appears twice")
        grid[key] = expanded
    return grid


def combination_params(values: dict[str, Any]) -> RunParams:
    """A :class:`RunParams` from grid values (the data keys are ignored)."""
    kw = {k: v for k, v in values.items() if k not in DATA_KEYS}
    kw.setdefault("fit", RUN_DEFAULT_FIT)
    if kw.get("arc_step") is not None:  # given in degrees, as ``--arc-step``
        kw["arc_step"] = math.radians(float(kw["arc_step"]))
    order = kw.pop("order", None)
    if order == "auto":
        kw["auto_order"] = True
    elif order is not None:
        kw["order"] = int(order)
    return RunParams(**kw)


@dataclass(frozen=True)
class Combination:
    """One point of the grid on one input."""

    index: int
    input: str
    values: dict[str, Any]

    @property
    def key(self) -> str:
        """A stable identity (input and values) used to find duplicates across shards."""
        return json.dumps({"input": self.input, **self.values}, sort_keys=True)


def combinations(inputs: Sequence[str], grid: dict[str, list[Any]]) -> list[Combination]:
    """Every combination, numbered in the deterministic sweep order.

    Raises
    ------
    ValueError
        ``sigma``/``seed`` with an input that is not a scenario, or a combination of
        values ``sonarproc run`` refuses (e.g. ``robust=huber`` with ``fit=spline``).
    """
    keys = list(grid)
    out: list[Combination] = []
    for inp in inputs:
        if is_scenario_path(inp) is False and any(k in grid for k in DATA_KEYS):
            raise GridSyntaxError("grid", f"sigma and seed need a scenario input, not {inp}")
        for combo in itertools.product(*(grid[k] for k in keys)):
            values = dict(zip(keys, combo, strict=True))
            out.append(Combination(len(out), inp, values))
    checked: set[str] = set()
    for c in out:
        sig = json.dumps({k: v for k, v in c.values.items() if k not in DATA_KEYS})
        if sig in checked:
            continue
        try:
            combination_params(c.values)
        except ValueError as err:
            raise GridSyntaxError("grid", f"combination {sig} is invalid: {err}") from None
        checked.add(sig)
    return out


def parse_shard(text: str) -> tuple[int, int]:
    """Parse ``I/N`` (0 <= I < N).

    Examples
    --------
    >>> parse_shard("2/8")
    (2, 8)
    """
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", text)
    if m is None or not 0 <= int(m.group(1)) < int(m.group(2)):
        raise GridSyntaxError("shard", f"bad value {text!r}; expected I/N with 0 <= I < N")
    return int(m.group(1)), int(m.group(2))


def shard_indices(total: int, shard: tuple[int, int]) -> range:
    """Indices of the combinations shard ``(I, N)`` runs: every N-th from I.

    Examples
    --------
    >>> list(shard_indices(7, (1, 3)))
    [1, 4]
    """
    i, n = shard
    return range(i, total, n)


def is_scenario_path(inp: str) -> bool | None:
    """True for a scenario YAML (or a shipped scenario's name), False for a log (a
    sonarlog, a ROS 1 bag, a ROS 2 bag directory or a Player log), None when the path is
    neither."""
    p = Path(inp)
    suffix = p.suffix.lower()
    if suffix in (".yaml", ".yml"):
        return True
    if suffix in (".h5", ".hdf5", ".bag", ".log") or (p / "metadata.yaml").is_file():
        return False
    if not p.exists() and len(p.parts) == 1:
        # the name of a shipped scenario (``fig12``, ``room-box``), as ``simulate`` takes
        from sonarsim.shipped import shipped_names

        if p.name in shipped_names("scenarios"):
            return True
    return None
