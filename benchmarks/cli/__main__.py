"""``python -m benchmarks.cli``: the command start-up benchmark (see the package docstring)."""

import sys

from benchmarks.cli._run import main

sys.exit(main())
