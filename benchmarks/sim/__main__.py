"""``python -m benchmarks.sim``: the simulation benchmark (see the package docstring)."""

import sys

from benchmarks.sim._run import main

sys.exit(main())
