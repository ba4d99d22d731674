"""Replicas at fleet scale: what each agent's world-model replica costs per change, and the
step overhead of simulated-outcome robots at 10 and at 50 robots in the same run.

Run with ``python -m benchmarks.replicas [--quick] [--profile] [--json F]``.

- ``_fleet``: one store (in this process, or in a child over Zenoh) and ``robots``
  simulated-outcome agents on this process's loop, one kitting cell each, every robot driving
  navigate steps at once; the agents each with their own replica (``own``: one ``skimesh
  agent`` process per robot) or sharing one (``shared``: ``run_agent(..., wm=client)``), and
  an ablation whose writes name no author (the store's agent-ownership check off). Figure:
  the median step overhead (wall time from start to result minus the simulated sleep), 50
  robots against 10, target <= 2x.
- ``_cost``: the changes of the 50-robot run replayed into one fresh replica: decode, apply
  and index, with a hold-condition listener, and a profile of where the time goes.
- ``_run``: the runs (repetitions interleaved), the results table, the command line;
  ``run_case`` (one case) is what ``tests/unit/benchmarks/test_replicas.py`` drives.
"""

from benchmarks.replicas._run import Case, main, run_case

__all__ = ["Case", "main", "run_case"]
