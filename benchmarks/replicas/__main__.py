"""``python -m benchmarks.replicas``: the replica benchmark (see the package docstring)."""

import sys

from benchmarks.replicas._run import main

sys.exit(main())
