"""``python -m sonard``: same as the ``sonard`` command."""

import sys

from sonard.cli import main

sys.exit(main())
