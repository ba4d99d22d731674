"""``python -m benchmarks.tasks``: the many-tasks benchmark (see the package docstring)."""

import sys

from benchmarks.tasks._run import main

sys.exit(main())
