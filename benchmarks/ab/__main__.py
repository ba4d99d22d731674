"""``python -m benchmarks.ab``: compare two checkouts (see the package docstring)."""

import sys

from benchmarks.ab._runner import main

sys.exit(main())
