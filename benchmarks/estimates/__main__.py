"""``python -m benchmarks.estimates``: the estimate-error benchmark (see the package docstring)."""

import sys

from benchmarks.estimates._run import main

sys.exit(main())
