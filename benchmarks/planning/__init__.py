"""Planning benchmarks: plan time beside the engine's own time on the same PDDL, and the
makespan of the partial-order schedule beside running the same plan sequentially, estimated
and measured.

    python -m benchmarks.planning               # full run
    python -m benchmarks.planning --quick       # 2x4 and 3x8 only
    python -m benchmarks.planning --json out.json

Run times, method and results: ``docs/benchmarks.md``, section "Planning".

Scenario: the kitting scene of ``tests.assets.planning`` (robots with a gripper, a camera and
a kit box on board, at a depot; gears spread over two part boxes at each of two stations; the
standard-library-shaped skills navigate / pick / place). Sizes are robots x parts. Goals:
``two`` = two parts into each robot's kit; ``all`` = every part into a kit, round robin.

Per size, goal and engine (median of the repetitions):

- *ours*: discovery from the world model (``agents_from_view``), task generation
  (``build_task``) and ``Planner.solve`` (compression, unified-planning problem, engine call,
  replay of the plan on the full task);
- *raw engine*: the same engine on the PDDL that ``Planner.solve`` handed it (the compressed
  task, written by ``emit_pddl``): Kairos parses and solves the text in-process (``anytime``
  off, as the unified-planning engine runs it); Fast Downward runs its driver on the files with
  the same search configuration, as a child process (``sys.executable``, stopped by PID);
- *makespan*: ``to_partial_order(plan)`` (with balancing) beside the plan's sequential
  duration, both estimated from the skills' durations; the ideal for independent work is
  1 / robots;
- *shared space* (``_space``): at the largest size, the plan time with the stations holding
  one robot each (the scene as it is) beside the same scene with room for every robot at
  every station (``robotCapacity`` = robots), solved alternately; target under 1 s at 8 x 40;
- *executed*: the measured makespan (``_execution``): a plan for the
  same sizes and goals run on simulated-outcome agents (``--time-scale``) as its partial order
  and forced sequential, the measured ratio beside that plan's estimated one.

Every solve has a time limit (``--timeout``), so a scale cliff shows as "timeout", not a hang.
"""

from benchmarks.planning._execution import TOLERANCE, Executed, execute_all, measure_execution
from benchmarks.planning._run import main

__all__ = ["TOLERANCE", "Executed", "execute_all", "main", "measure_execution"]
