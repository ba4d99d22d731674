"""A soak benchmark: the router's memory over thousands of tasks (``python -m benchmarks.soak``)."""
