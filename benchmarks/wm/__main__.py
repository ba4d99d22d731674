"""``python -m benchmarks.wm``: the world-model benchmark (see the package docstring)."""

import sys

from benchmarks.wm._run import main

sys.exit(main())
