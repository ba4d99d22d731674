"""``python -m benchmarks.space``: the shared-space benchmark (see the package docstring)."""

import sys

from benchmarks.space._run import main

sys.exit(main())
