"""Planning at fleet scale: ``python -m benchmarks.fleet [--robots N ...] [--json F]``.

The site is ``tests.assets.planning.fleet``: one kitting cell per robot (a one-robot station
with a part box of two gears), every robot at the shared depot with a kit box on its deck,
offering the standard library's navigate, locate, pick, place and serve. For each fleet size,
in a fresh child process (so its peak memory is its own):

- ``all``: one gear of its own cell into each robot's kit (one part per robot);
- ``one``: the same for robot 1 only, in the world of ``N`` robots.

Each goal is planned as the task agent plans it (``Planner.plan_sync``: the task built from
the discovered agents and the world model, then solved) by the decomposed planner (the
default) and, where it finishes within ``--monolithic-limit`` seconds, by the monolithic one
(the oracle): the time to build the task and plan (median of ``--reps``, after a warm-up on
the same world), the partial order's estimated makespan of both, and the child's peak RSS.
The same-run baselines: a goal for one robot in a world of one robot (the 2x target of a
one-robot goal in a large world) and the monolithic makespan (the 10 % target).

``_run`` holds the whole benchmark: the child's measurement, the rows, the command line.
"""

from ._run import Case as Case
from ._run import main as main
from ._run import measure as measure

__all__ = ["Case", "main", "measure"]
