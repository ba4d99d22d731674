"""A/B comparison of two checkouts: the same benchmark commands run in each, interleaved.

    python -m benchmarks.ab --a /path/to/old/checkout --b .            # every benchmark
    python -m benchmarks.ab --a ../old --bench wm --bench skills --runs 5

Each run is a subprocess ``python -m benchmarks.<name> <quick args> --json FILE`` with its cwd
and ``PYTHONPATH`` in that checkout (``_runner``; the cheapest meaningful arguments per
benchmark are :data:`QUICK_ARGS`). Runs go A, B, B, A, A, B... (each pair in turn), so a drift of
the machine's load favours neither side. From every run's JSON the headline figures are read
(:func:`figures`: the results table, or the planning cases), and per figure the pairs give
B/A: its median, its smallest and largest, the noise between consecutive runs of one side
(A/A, B/B) and the B/A of
the figure's same-run ratio to its baseline (``_figures``). How to run it and how to read it:
``docs/benchmarks.md``, section "A/B comparison".
"""

from benchmarks.ab._figures import (
    Comparison,
    Figure,
    compare,
    figures,
    format_comparisons,
    higher_is_better,
    noise_factor,
    verdict,
)
from benchmarks.ab._runner import QUICK_ARGS, main, run_ab

__all__ = [
    "QUICK_ARGS",
    "Comparison",
    "Figure",
    "compare",
    "figures",
    "format_comparisons",
    "higher_is_better",
    "main",
    "noise_factor",
    "run_ab",
    "verdict",
]
