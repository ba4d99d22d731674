"""Simulation benchmark: each scenario with every robot and driver working, beside bare
``mj_step`` of the same model driven by the same set-points, in the same run.

    python -m benchmarks.sim                         # full run
    python -m benchmarks.sim --quick                 # smoke run
    python -m benchmarks.sim --in-process            # the single-process layout only
    python -m benchmarks.sim --layout router-apart   # any layouts, the first one headline
    python -m benchmarks.sim --json results.json
    python -m benchmarks.sim --fleet-only            # the fleet case only (--fleet N: N robots)

Per scenario (run times, method and results: ``docs/benchmarks.md``, section "Simulation"):

1. **full system, fast mode**: ``SimWorld`` (controllers at 100 Hz, IK every tick of straight
   moves, grasp logic, sensors) with every device served over Zenoh (states published at
   25 Hz) and rerun logging to a file, driven by a workload written against the device
   Protocols (``_workload``: pick-and-place on every robot at once, sensors read
   every 0.5 s) through the remote proxies. Layouts (``_system``): *deployed*,
   the headline, with the router, the world and its device server in this process and the
   workload in a client process of its own (``_client``), as skill agents are;
   *in-process*, the client's session and workload in this process too (its loop, its GIL);
   *router-apart* (on request), as deployed with the router in a process of its own. Figure:
   wall time of this process per simulated second.
2. **baseline**: a fresh copy of the same model stepped with bare ``mj_step(m, d, nstep=5)``
   per control tick, replaying the exact set-points, weld switches, weld poses and gripper
   force limits the controllers produced in run 1 (recorded every tick), from its start (the
   ticks before the measured window untimed), right after it: the run's physics bit for bit
   (:func:`step_through`, ``_measure``). Ratio = overhead;
   target < 2x. Runs 1 and 2 are repeated (``--repeat``, 9 by default; the layouts take turns
   going first): figures are medians, the ratio the median of the pairs' ratios.
3. bare stepping at rest (no motion); real time: the same system paced by the wall clock in
   the headline layout (target: real-time factor 1, no slips); the CPU an idle world costs in
   real time (beside bare stepping at rest); pick-and-place success; stop-to-halt time.
4. **fleet** (``_fleet``, ``--fleet N``, 40 by default, 0: skip): a generated scenario of N
   mobile manipulators, each with a kitting cell of its own, every base driving out and back
   at once through the remote proxies from a client process, the world in real time recorded
   with rerun: real-time factor and slips beside a fleet of 4 in the same run (target: >= 0.98,
   no slip), and N robots in paced runs (``WorldOptions.handover`` 1 s: the simulation thread
   keeps the clock) beside them.

Child processes (client, fleet client, router) are ``sys.executable`` children of this script
(``--role``), on 127.0.0.1 only (free port, multicast scouting off), always stopped by their
PID. ``_run`` holds the results table and the command line.
"""

from benchmarks.sim._measure import step_through
from benchmarks.sim._run import main
from benchmarks.sim._system import LAYOUTS, Tap, Window, WorldTruth, full_system
from benchmarks.sim._workload import WORKLOADS, Truth, drive

__all__ = [
    "LAYOUTS",
    "WORKLOADS",
    "Tap",
    "Truth",
    "Window",
    "WorldTruth",
    "drive",
    "full_system",
    "main",
    "step_through",
]
