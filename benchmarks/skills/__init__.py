"""Skill-layer benchmarks: the round trip of a no-op skill run, and runs/s with concurrent callers.

    python -m benchmarks.skills            # full run
    python -m benchmarks.skills --quick    # smoke run
    python -m benchmarks.skills --json results.json

Figures (each beside a baseline measured in the same run; run times, method and results:
``docs/benchmarks.md``, section "Skills"):

1. one no-op skill run, start -> final result, from this process to the agent process:
   ``AgentClient.run("noop")`` with the client's shared progress subscription (``async with
   AgentClient(...)``), p50 / p99 over >= 2,000 runs; and the same without the shared
   subscription (each run subscribes and watches liveliness first);
2. baselines to the same agent process: a raw Zenoh ``get`` round trip (synchronous
   zenoh-python, no event loop) and a ``Mesh.request`` round trip (the anyio bridge on both
   ends: what any skill request pays);
3. runs/s with 8 concurrent callers (one shared client), against 1 caller;
4. stop -> ``preempted``: a client stops a run of ``idle`` (waits in ``execute`` until
   stopped) in the agent process; time from the ``StopRun`` sent until the ``preempted``
   result arrives, on the run's progress stream and as the ``StopRun`` reply
   (``AgentClient.stop``), beside the raw get round trip of 2.

Processes: a Zenoh router, an in-memory world-model store and the agent (``noop`` from
``configs/agents/noop.toml`` plus :class:`Idle` from this module, and two echo queryables for
the baselines) are children of this script (``--role``), on 127.0.0.1 only (free port,
multicast scouting off), stopped by PID. ``_setup`` holds the plan, the agent and the child
roles, ``_measure`` the measurements, ``_run`` the results table and the command line.
"""

from benchmarks.skills._run import main, run
from benchmarks.skills._setup import FULL, QUICK, Idle, Plan

__all__ = ["FULL", "QUICK", "Idle", "Plan", "main", "run"]
