"""``python -m benchmarks.skills``: the skill benchmark (see the package docstring)."""

import sys

from benchmarks.skills._run import main

sys.exit(main())
