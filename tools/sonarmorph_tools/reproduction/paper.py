"""What the paper reports: per figure, Table 1 and Table 2, and the study settings.

Every value here is transcribed from Baskent & Barshan (1999); ``None`` where the paper
reports nothing. :data:`AUTO` is our automatic method's settings and
:data:`ARC_STEPS_DEG` the angular steps of the paper-style sampled arcs study.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "ARC_STEPS_DEG",
    "AUTO",
    "PAPER",
    "TABLE1",
    "TABLE2",
    "TABLES",
    "PaperRow",
    "paper_row",
    "sigma_paper_cm",
]


@dataclass(frozen=True)
class PaperRow:
    """What the paper reports for one figure (``None``: not reported)."""

    figure: str
    ops: str
    order: int
    e: float | None = None
    f_c: float | None = None
    E1_cm: float | None = None
    E2: float | None = None
    t_cpu_s: float | None = None
    note: str = ""


#: Per scenario (file stem): the paper's operations, order m and reported values.
PAPER: dict[str, PaperRow] = {
    "fig02": PaperRow("Fig. 4", "thinning:3", 9, 0.052, 0.341, 3.18, 0.036, 1.11),
    "fig06a": PaperRow("Fig. 7a/c", "closing,thinning:5", 8, 0.276, 0.772, 3.03, 0.127, 4.51),
    "fig06b": PaperRow("Fig. 7b/d", "thinning:3", 7, 0.353, 0.864, 7.85, 0.329, 1.28),
    "fig08a": PaperRow(
        "Fig. 8a", "thinning:5", 11, note="not processed in the paper; n, m of Fig. 9"
    ),
    "fig08b": PaperRow("Fig. 9", "thinning:5", 11, 0.050, 0.464, 3.57, 0.040),
    "fig10b": PaperRow("Fig. 11a/c", "thinning:2", 6, 0.296, 0.566, 3.92, 0.164, 0.49),
    "fig10c": PaperRow("Fig. 11b/d", "thinning:5", 6, 0.133, 0.610, 2.30, 0.090, 0.73),
    "fig12": PaperRow("Fig. 12c/d", "thinning:6", 10, 0.245, 0.777, 2.88, 0.283, 0.51),
    "fig13": PaperRow(
        "Fig. 13", "thinning:3", 10, None, None, 3.28, 0.322, note="m not given; 10 as Fig. 12"
    ),
    "fig16": PaperRow(
        "Fig. 17",
        "erosion,pruning",
        10,
        E1_cm=3.59,
        E2=0.263,
        t_cpu_s=0.27,
        note="paper's truth: structured light",
    ),
    "fig18": PaperRow(
        "Fig. 19",
        "erosion,pruning",
        10,
        E1_cm=1.41,
        E2=0.156,
        t_cpu_s=0.39,
        note="paper's truth: structured light",
    ),
}

#: Table 1 of the paper (Fig. 2 map, m = 9): operations and e, f_c, E1 (cm), E2, t_CPU.
TABLE1: tuple[PaperRow, ...] = (
    PaperRow("n = 1 (pruning)", "thinning:1", 9, 0.168, 0.924, 7.83, 0.089, 1.15),
    PaperRow("n = 2", "thinning:2", 9, 0.074, 0.637, 4.42, 0.050, 1.12),
    PaperRow("n = 3", "thinning:3", 9, 0.052, 0.341, 3.18, 0.036, 1.11),
    PaperRow("n = 4", "thinning:4", 9, 0.045, 0.160, 5.37, 0.061, 1.10),
    PaperRow("n = 5", "thinning:5", 9, 0.012, 0.063, 16.21, 0.183, 1.09),
    PaperRow("n = 6", "thinning:6", 9, 0.014, 0.021, 464.30, 5.246, 1.10),
    PaperRow("n = 7", "thinning:7", 9, 0.007, 0.003, 1915.45, 21.641, 1.10),
    PaperRow("n = 8 (erosion)", "thinning:8", 9, None, 0.000, None, None, 1.10),
    PaperRow("closing, n = 3", "closing,thinning:3", 9, 0.121, 0.760, 6.72, 0.076, 7.10),
    PaperRow("closing, n = 4", "closing,thinning:4", 9, 0.122, 0.641, 6.88, 0.078, 7.09),
)


#: Table 2 of the paper (the Fig. 18 surface, measured, m = 10): E1 (cm), E2, t_CPU.
TABLE2: tuple[PaperRow, ...] = tuple(
    PaperRow(label, ops, 10, E1_cm=e1, E2=e2, t_cpu_s=t)
    for label, ops, e1, e2, t in (
        ("n = 1 (pruning)", "thinning:1", 4.98, 0.554, 0.41),
        ("n = 2", "thinning:2", 4.84, 0.539, 0.41),
        ("n = 3", "thinning:3", 4.07, 0.452, 0.40),
        ("n = 4", "thinning:4", 3.28, 0.364, 0.39),
        ("n = 5", "thinning:5", 2.58, 0.287, 0.37),
        ("n = 6", "thinning:6", 1.96, 0.218, 0.36),
        ("n = 7", "thinning:7", 1.63, 0.182, 0.35),
        ("n = 8 (erosion)", "thinning:8", 1.42, 0.158, 0.34),
        ("erosion, pruning", "erosion,pruning", 1.41, 0.156, 0.39),
        ("erosion, n = 2", "erosion,thinning:2", 1.50, 0.167, 0.39),
    )
)

#: Which scenario each study table runs on.
TABLES = {"fig02": ("Table 1: every operation on the Fig. 2 map (scenario fig02, m = 9)", TABLE1),
          "fig18": ("Table 2: the Fig. 18 surface (scenario fig18, m = 10; the paper's values "
                    "are measurements with the real robot)", TABLE2)}  # fmt: skip


#: Our automatic method, no ground truth: the count vote ``vote:auto`` and its crest
#: ``ridge``, a Huber fit weighted by the counts, m by cross-validation, judged on the
#: columns between the first and last with points.
AUTO = {"ops": "vote:auto,ridge", "robust": "huber", "auto_order": True, "span": "points"}


#: Angular steps (deg) of the paper-style sampled arcs study (``--arc-step``).
ARC_STEPS_DEG: tuple[float, ...] = (0.5, 1.0, 2.0)


def paper_row(name: str) -> PaperRow:
    """The paper's row for scenario ``name``, or the default run for one not in the paper.

    Examples
    --------
    >>> paper_row("fig12").figure, paper_row("wavy-walk").note
    ('Fig. 12c/d', 'not in the paper')
    """
    return PAPER.get(name, PaperRow("—", "thinning:3", 9, note="not in the paper"))


def sigma_paper_cm(p: PaperRow) -> float | None:
    """sigma_y of the paper's surface (cm), from its E1 / E2 (Eq. 4).

    Examples
    --------
    >>> round(sigma_paper_cm(PAPER["fig12"]), 2)
    10.18
    """
    if p.E1_cm is None or not p.E2:
        return None
    return p.E1_cm / p.E2
