"""What a run leaves behind: report.json, profile.csv, figures and a self-contained HTML.

``run_report`` writes a run's directory; ``plots`` draws its figures; ``html`` renders
the page; ``comparison`` writes ``sonarproc compare``'s files; ``atomic`` rewrites a
report directory under a live reader; ``units`` and ``summary`` format numbers for people
(lengths in cm); ``jsonable`` makes values strict JSON.
"""

from sonarproc.report.run_report import (
    REPORT_FILES,
    default_out_dir,
    profile_points,
    report_dict,
    write_profile_csv,
    write_report,
)

__all__ = [
    "REPORT_FILES",
    "default_out_dir",
    "profile_points",
    "report_dict",
    "write_profile_csv",
    "write_report",
]
