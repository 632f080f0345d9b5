"""Parameters of a ``sonarproc run``: one validated, immutable record."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal

from sonarproc.errors import ParameterError
from sonarproc.fit import FitKind

__all__ = ["DEFAULT_ORDER", "PAPER_OPS", "RunParams", "parse_bbox", "parse_point"]

#: Default fit order per fit kind: the paper's m = 9 (Table 1) for a polynomial; harmonics
#: for a polar fit; the spline is always cubic.
#: The paper's morphological operations (section 4: thinning to a one-cell-wide curve).
PAPER_OPS = "thinning:3"

DEFAULT_ORDER: dict[str, int] = {"poly": 9, "spline": 3, "polar": 16, "auto": 9}

FIT_KINDS = ("poly", "spline", "polar", "auto")
ROBUST_KINDS = ("none", "huber")
SPANS = ("truth", "points")
#: Highest order ``--order auto`` tries.
MAX_AUTO_ORDER = 15
#: finest --arc-step (rad): see RunParams.validate
MIN_ARC_STEP = math.radians(0.01)


@dataclass(frozen=True)
class RunParams:
    """What ``sonarproc run`` does to a log.

    Attributes
    ----------
    cell : float
        Grid cell size (m).
    bbox : (xmin, xmax, ymin, ymax) or None
        Map extent (m); ``None`` covers every arc.
    ops : str
        Morphological operations, e.g. ``"closing,thinning:3"``.
    fit : {"poly", "spline", "polar", "auto"}
        Fit kind. ``auto``: the paper's polynomial where the kept cells are one curve
        y = f(x), else a line, arc or spline per surface
        (:mod:`sonarproc.pipeline.surfacefit`).
    order : int or None
        Polynomial order m, or polar harmonics; ``None`` uses :data:`DEFAULT_ORDER`.
    smooth : float or None
        Spline roughness penalty; ``None`` chooses it by cross-validation.
    centre : (x, y) or None
        Centre of a polar fit (m); ``None`` uses the mean robot position.
    drop_crosstalk : bool
        Skip readings flagged as suspected crosstalk (flag bit 1).
    auto_order : bool
        Choose the polynomial order by cross-validation on the points (``--order auto``;
        beyond the paper); :attr:`order` is then ignored.
    robust : {"none", "huber"}
        ``huber``: Huber-IRLS polynomial over the points, each weighted by the number of
        arcs crossing its cell (beyond the paper); ``none``: the paper's least squares.
    span : {"truth", "points"}
        Columns the metrics use: every column the truth spans inside the map (the paper),
        or only those between the first and last column left with points.
    max_cells : int
        Refuse maps larger than this many cells (a guard against a stray reading).
    arc_step : float or None
        ``None`` (default): each arc is a gap-free 8-connected chain of cells
        (:func:`sonarproc.arcs.rasterize`). A step (rad, > 0): each arc is drawn
        paper-style as samples every ``arc_step`` of angle, one cell per sample
        (:mod:`sonarproc.arcs._sampled`; ``--arc-step DEG``).
    align : bool
        Correct odometry drift before mapping where the echoes show it
        (:mod:`sonarproc.pipeline.alignment`; ``--no-align`` turns it off).
    """

    cell: float = 0.01
    bbox: tuple[float, float, float, float] | None = None
    ops: str = PAPER_OPS
    fit: FitKind | Literal["auto"] = "poly"
    order: int | None = None
    smooth: float | None = None
    centre: tuple[float, float] | None = None
    drop_crosstalk: bool = False
    auto_order: bool = False
    robust: Literal["none", "huber"] = "none"
    span: Literal["truth", "points"] = "truth"
    max_cells: int = 400_000_000
    arc_step: float | None = None
    align: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.cell) and self.cell > 0):
            raise ParameterError("cell", f"must be > 0 m, got {self.cell}")
        if self.bbox is not None:
            xmin, xmax, ymin, ymax = self.bbox
            if not all(math.isfinite(v) for v in self.bbox) or xmax <= xmin or ymax <= ymin:
                raise ParameterError(
                    "bbox",
                    "must be finite xmin,xmax,ymin,ymax with xmin < xmax and "
                    f"ymin < ymax, got {','.join(f'{v:g}' for v in self.bbox)}",
                )
        if self.fit not in FIT_KINDS:
            raise ParameterError("fit", f"must be one of {', '.join(FIT_KINDS)}, got {self.fit!r}")
        if self.order is not None and not 0 <= self.order <= 60:
            raise ParameterError("order", f"must be between 0 and 60, got {self.order}")
        if self.smooth is not None and not (math.isfinite(self.smooth) and self.smooth >= 0):
            raise ParameterError("smooth", f"must be >= 0, got {self.smooth}")
        if self.centre is not None and not all(math.isfinite(v) for v in self.centre):
            raise ParameterError("centre", "must be finite")
        if self.robust not in ROBUST_KINDS:
            raise ParameterError(
                "robust", f"must be one of {', '.join(ROBUST_KINDS)}, got {self.robust!r}"
            )
        if self.arc_step is not None and not (math.isfinite(self.arc_step) and self.arc_step > 0):
            raise ParameterError(
                "arc_step", f"must be > 0, got {math.degrees(self.arc_step):g} deg"
            )
        # 0.01 deg puts a 10.7 m arc's samples 1.9 mm apart, finer than any map cell: a finer
        # step changes no cell and only multiplies the samples (1e-9 deg: 10^10 per arc)
        if self.arc_step is not None and self.arc_step < MIN_ARC_STEP:
            raise ParameterError(
                "arc_step",
                f"must be >= {math.degrees(MIN_ARC_STEP):g} deg, "
                f"got {math.degrees(self.arc_step):g} deg",
            )
        if self.span not in SPANS:
            raise ParameterError("span", f"must be one of {', '.join(SPANS)}, got {self.span!r}")
        if (self.auto_order or self.robust != "none") and self.fit not in ("poly", "auto"):
            raise ParameterError("fit", "must be poly for an automatic order or a robust fit")
        if self.span == "points" and self.fit == "polar":
            raise ParameterError("span", "points applies to a poly or spline fit, not polar")

    @property
    def fit_order(self) -> int:
        """The order actually used: :attr:`order` or the fit kind's default."""
        if self.fit == "spline":
            return 3
        return self.order if self.order is not None else DEFAULT_ORDER[self.fit]

    def to_json(self) -> dict[str, Any]:
        """Return a JSON-ready mapping, with the effective fit order."""
        d = asdict(self)
        d["bbox"] = list(self.bbox) if self.bbox else None
        d["centre"] = list(self.centre) if self.centre else None
        d["order"] = "auto" if self.auto_order else self.fit_order
        return d


def _floats(text: str, count: int, what: str) -> tuple[float, ...]:
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != count:
        raise ParameterError(what, f"must be {count} comma-separated numbers, got {text!r}")
    return values


def parse_bbox(text: str) -> tuple[float, float, float, float]:
    """Parse ``"xmin,xmax,ymin,ymax"`` (m).

    Examples
    --------
    >>> parse_bbox("-1, 2, 0, 3.5")
    (-1.0, 2.0, 0.0, 3.5)
    """
    a, b, c, d = _floats(text, 4, "bbox")
    return (a, b, c, d)


def parse_point(text: str) -> tuple[float, float]:
    """Parse ``"x,y"`` (m)."""
    a, b = _floats(text, 2, "centre")
    return (a, b)
