"""What a run leaves behind: report.json, profile.csv, figures and a self-contained HTML.

``run_report`` writes a run's directory; ``plots`` draws its figures as matplotlib
``Figure`` objects (:func:`arcmap_figure`, :func:`processed_figure`, :func:`fit_figure`)
in the look ``style`` defines for every figure, with lines cut to the view by ``view``;
``html`` renders the page; ``comparison`` writes ``sonarproc compare``'s files and draws
its figure; ``atomic`` rewrites a report directory under a live reader; ``units`` and
``summary`` format numbers for people (lengths in cm); ``jsonable`` makes values strict
JSON. matplotlib is imported only when a figure is drawn.
"""

from sonarproc.report.plots import arcmap_figure, fit_figure, processed_figure
from sonarproc.report.run_report import (
    DEFAULT_FIGURES,
    REPORT_FILES,
    default_out_dir,
    profile_points,
    read_report,
    report_dict,
    report_files,
    upgrade_report,
    write_profile_csv,
    write_report,
)

__all__ = [
    "DEFAULT_FIGURES",
    "REPORT_FILES",
    "arcmap_figure",
    "default_out_dir",
    "fit_figure",
    "processed_figure",
    "profile_points",
    "read_report",
    "report_dict",
    "report_files",
    "upgrade_report",
    "write_profile_csv",
    "write_report",
]
