"""``python -m ugpcl``: the same as the ``ugpcl`` console script (used where the package is not installed)."""

from __future__ import annotations

import sys

from .cli import main

sys.exit(main())
