"""Tools that regenerate the documentation's tables and figures; not part of the product.

They live beside the packages, not in them, so an installed wheel carries none of them.
Each is a ``python -m`` module that takes explicit output paths and runs against the
installed (or editable) packages from a checkout, with ``tools/`` on ``PYTHONPATH``
(the ``./scripts`` that call them set it):

- :mod:`~sonarmorph_tools.reproduce` (``./scripts/reproduce``): ``docs/reproduction.md``,
  the paper's numbers beside ours on the paper's scenarios (studies in
  :mod:`~sonarmorph_tools.reproduction`);
- :mod:`~sonarmorph_tools.noise_sweep` (``./scripts/noise-sweep``): ``docs/noise-sweep.md``
  and ``docs/fig14.png``;
- :mod:`~sonarmorph_tools.methods_table`: the generated tables of ``docs/methods.md``, on
  the shipped scenarios and the test scenarios of ``tests/data/scenarios``, with
  :mod:`~sonarmorph_tools.auto_judge` judging ``--auto`` by the truth;
- :mod:`~sonarmorph_tools.gallery` (``./scripts/gallery``): ``docs/gallery.md``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["REPO_ROOT", "TEST_SCENARIOS"]

#: The checkout this package sits in (``tools/sonarmorph_tools/`` two levels down).
REPO_ROOT = Path(__file__).resolve().parents[2]
#: The scenarios written to test and judge ``--auto``: not shipped, so read from the checkout.
TEST_SCENARIOS = REPO_ROOT / "tests" / "data" / "scenarios"
