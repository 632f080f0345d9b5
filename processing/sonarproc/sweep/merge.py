"""Merging the shards of a parameter sweep, and choosing the best parameters.

Shards written by :func:`sonarproc.sweep.write_sweep` (on one machine or on a cluster, one
array task each) come back together here: :func:`merge_shards` checks that they are of one
sweep and reports missing, repeated and conflicting combinations; :func:`best_rows` picks
the best parameters per input, by E1 with a truth profile and without ground truth
otherwise.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sonarproc.errors import InputError

__all__ = ["MergeResult", "best_rows", "merge_shards"]


@dataclass
class MergeResult:
    """Merged shards: the rows by index, and what is missing or repeated."""

    rows: list[dict[str, Any]]
    total: int
    missing: list[int]
    duplicates: list[int]
    conflicting: list[int]
    manifests: list[Path]


def merge_shards(dirs: Sequence[Path]) -> MergeResult:
    """Merge the shard outputs found in ``dirs`` into one table.

    Every ``results*.json`` manifest names its table; all must come from the same grid
    and inputs. Rows repeated across shards are kept once (``duplicates``; those whose
    metrics differ are listed in ``conflicting`` too); indices no shard ran are
    ``missing``.

    Raises
    ------
    ValueError
        No manifest found, or manifests of different sweeps.
    """
    manifests = sorted(
        {p for d in dirs for p in Path(d).glob("results*.json") if p.name != "results.merged.json"}
    )
    if not manifests:
        raise InputError(f"no sweep outputs (results*.json) in {', '.join(map(str, dirs))}")
    ref: dict[str, Any] | None = None
    by_index: dict[int, dict[str, Any]] = {}
    duplicates: set[int] = set()
    conflicting: set[int] = set()
    for mpath in manifests:
        try:
            man = json.loads(mpath.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as err:
            raise InputError(f"{mpath}: unreadable sweep manifest ({err})") from None
        ident = {k: man.get(k) for k in ("grid", "inputs", "total")}
        if ref is None:
            ref = ident
        elif ident != ref:
            raise InputError(f"{mpath}: from a different sweep (grid, inputs or size differ)")
        table = mpath.with_name(str(man.get("table", "")))
        with table.open(encoding="utf-8") as fh:
            for line in fh:
                if not line.strip():
                    continue
                row = json.loads(line)
                i = int(row["index"])
                if i in by_index:
                    duplicates.add(i)
                    a = {k: v for k, v in by_index[i].items() if k != "t_cpu_s"}
                    b = {k: v for k, v in row.items() if k != "t_cpu_s"}
                    if a != b:
                        conflicting.add(i)
                    continue
                by_index[i] = row
    assert ref is not None
    total = int(ref["total"])
    missing = sorted(set(range(total)) - set(by_index))
    rows = [by_index[i] for i in sorted(by_index)]
    return MergeResult(rows, total, missing, sorted(duplicates), sorted(conflicting), manifests)


#: Parameters a person chooses; the rest of a row's values (noise sigma, seed) are data.
TUNED = ("ops", "order", "cell", "fit", "robust", "span", "arc_step")


def _best_by_e1(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The setting of the tuned parameters with the least E1, averaged over the data.

    Noise and seed are not choices: a setting that ran on several of them is scored by
    its mean E1 over all of them (``E1_m_mean``, ``runs``), so the answer names
    parameters only.
    """
    groups: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(json.dumps([r.get(k) for k in TUNED]), []).append(r)
    varied = any(r.get("sigma") is not None or r.get("seed") is not None for r in rows)
    if not varied or all(len(g) == 1 for g in groups.values()):
        best = min(rows, key=lambda r: (r["E1_m"], r["index"]))
        return {"criterion": "min E1_m (truth)", "row": best}
    scored = [(sum(r["E1_m"] for r in g) / len(g), g[0]["index"], g) for g in groups.values()]
    mean, _, group = min(scored, key=lambda t: (t[0], t[1]))
    row = {k: v for k, v in group[0].items() if k not in ("sigma", "seed")}
    row.update(E1_m_mean=mean, runs=len(group))
    return {"criterion": "min mean E1_m over noise and seeds (truth)", "row": row}


def best_rows(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The best parameters for each input.

    With a truth profile: the smallest ``E1_m`` (averaged over noise and seeds when the
    sweep varied them: see :func:`_best_by_e1`). Without: among the runs that keep at
    least 90 % of the best coverage ``f_c``, the smallest ``cv_score`` (the 5-fold
    cross-validated held-out loss of the fitted order on the run's own points, from
    :func:`sonarproc.fit.select_order_cv`: no ground truth); if no run has one, the
    largest ``f_c``.

    Returns
    -------
    dict
        ``{input: {"criterion": ..., "row": row}}``.
    """
    out: dict[str, dict[str, Any]] = {}
    for inp in dict.fromkeys(r["input"] for r in rows):
        good = [r for r in rows if r["input"] == inp and r.get("ok") and r.get("fit_ok")]
        with_e1 = [r for r in good if r.get("E1_m") is not None]
        if with_e1:
            out[inp] = _best_by_e1(with_e1)
            continue
        # several surfaces against a multi-surface truth: E1 is not defined, precision is
        # (the complete runs first: a run that fits one wall well is not the best map)
        with_p = [r for r in good if r.get("precision_m") is not None]
        if with_p:
            best = min(
                with_p,
                key=lambda r: (-round(r.get("completeness") or 0.0, 2), r["precision_m"],
                               r["index"]),
            )  # fmt: skip
            crit = "max completeness (to 0.01), then min precision_m (truth)"
            out[inp] = {"criterion": crit, "row": best}
            continue
        cover = [r for r in good if r.get("f_c") is not None]
        if not cover:
            continue
        top = max(r["f_c"] for r in cover)
        near = [r for r in cover if r["f_c"] >= 0.9 * top]
        scored = [r for r in near if r.get("cv_score") is not None]
        if scored:
            best = min(scored, key=lambda r: (r["cv_score"], r["index"]))
            crit = "min cv_score among f_c >= 0.9 max f_c (no truth)"
        else:
            best = max(cover, key=lambda r: (r["f_c"], -r["index"]))
            crit = "max f_c (no truth)"
        out[inp] = {"criterion": crit, "row": best}
    return out
