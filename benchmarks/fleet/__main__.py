"""``python -m benchmarks.fleet``: planning at fleet scale (see the package docstring)."""

import sys

from benchmarks.fleet._run import main

sys.exit(main())
