"""``python -m benchmarks.planning``: the planning benchmark (see the package docstring)."""

import sys

from benchmarks.planning._run import main

sys.exit(main())
