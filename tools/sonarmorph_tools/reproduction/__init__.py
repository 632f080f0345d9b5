"""The studies of ``docs/reproduction.md``, one module each.

- :mod:`~.paper`: what the paper reports (per figure, Tables 1 and 2) and the settings;
- :mod:`~.outcome`: our numbers for one run and the shared table cell formats;
- :mod:`~.figures`: the per-figure tables (the paper's n and m; our automatic method);
- :mod:`~.paper_tables`: Table 1 (the Fig. 2 map) and Table 2 (the Fig. 18 surface);
- :mod:`~.sampled`: paper-style sampled arcs beside our connected arcs;
- :mod:`~.own_echo`: did Figs. 10-12 use each sensor's own echo only? (t_CPU and errors);
  :mod:`~.own_echo_runs`: the simulations and runs it compares;
- :mod:`~.multi_surface`: multi-surface scenes and a sonard ring log, default options;
- :mod:`~.discussion`, :mod:`~.document`: the hand-written part and the whole text;
- :mod:`~.runner`: :func:`reproduce`, which runs them all.

The command line is :mod:`sonarmorph_tools.reproduce`.
"""

from sonarmorph_tools.reproduction.document import render_markdown
from sonarmorph_tools.reproduction.outcome import AutoOutcome, Outcome, outcome_line
from sonarmorph_tools.reproduction.paper import (
    ARC_STEPS_DEG,
    AUTO,
    PAPER,
    TABLE1,
    TABLE2,
    TABLES,
    PaperRow,
)
from sonarmorph_tools.reproduction.runner import reproduce
from sonarmorph_tools.reproduction.sampled import SampledRow

__all__ = [
    "ARC_STEPS_DEG",
    "AUTO",
    "PAPER",
    "TABLE1",
    "TABLE2",
    "TABLES",
    "AutoOutcome",
    "Outcome",
    "PaperRow",
    "SampledRow",
    "outcome_line",
    "render_markdown",
    "reproduce",
]
