"""Many tasks at once: ``python -m benchmarks.tasks [--robots N] [--rounds R] [--json F]``.

Throughput of one task service running every submitted task at once (each claims the robots
and objects its plan needs, :mod:`task_agent.claims`) against the same goals submitted one
after the other, the same-run baseline. In-process (the task-layer test fleet,
``tests.assets.task_fleet``: real agent cores in simulated-outcome mode, each run lasting its
description's duration times ``--time-scale``; an in-memory world-model store; no Zenoh), a
fresh fleet per run, the mode that goes first alternating from round to round.

Cases (``_workload``): ``independent`` (one goal per robot, nothing shared), ``shared-boxes``
(one goal per robot, the parts in two shared part boxes, which the tasks claim) and
``overlapping`` (two goals for one robot's kit: the second waits for the first). Per case:
tasks per minute and makespan (first submission to the last task's end), at once against one
at a time, the ratio the median of the rounds' ratios; per run, what each task was seen
waiting for, the planning time and the replans. It exits 1 if a task did not succeed, if
steps of two tasks ever overlapped on one robot, or if the second ``overlapping`` task did not
wait for the first.

``_workload`` holds the cases and one run; ``_run`` the rounds, the rows and the command line.
"""

from ._run import main as main
from ._run import measure as measure

__all__ = ["main", "measure"]
