"""``python -m dvr_gl``: the ``dvr`` command (for environments whose scripts folder is not on PATH)."""

import sys

from .apps.cli import main

sys.exit(main())
