"""The project's benchmarks, one sub-package each (``python -m benchmarks.<name>``: ``wm``,
``skills``, ``sim``, ``planning``, ``cli``, ``replicas``, ``estimates``, ``space``, ``soak``,
``tasks``), the shared helpers (``common``) and the A/B comparison of two checkouts (``ab``).
Method and results: ``docs/benchmarks.md``."""
