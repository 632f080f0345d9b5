"""``python -m sonard.soak DURATION``: see :mod:`sonard.soak.runner`."""

import sys

from sonard.soak.runner import main

sys.exit(main())
