"""World-model benchmarks: durable transactions/s, change propagation, resolve on 10k elements.

    python -m benchmarks.wm            # full run
    python -m benchmarks.wm --quick    # smoke run
    python -m benchmarks.wm --json results.json

Run times, method and results: ``docs/benchmarks.md``, section "World model". Every figure is
printed beside a baseline measured in the same run, with the ratio:

1. durable tx/s of :class:`~wm_store.WmStore` (data dir in a temp folder) with durability
   ``group`` against ``fsync`` and ``none`` at 1, 16 and 64 concurrent writers, in-process;
   then through the whole Zenoh path (``WmClient`` -> router -> store process -> fsync ->
   change -> replica) against the in-process figure (``_tx``);
2. change propagation: publication by the store process -> ``on_change`` in a replica in a
   third process, one-way, on ``CLOCK_MONOTONIC`` (``time.monotonic_ns``, one clock for every
   process on Linux), against the raw Zenoh get round trip and the raw put -> subscriber time
   between two processes (``_latency``);
3. ``resolve`` on a 10k-element replica against the same questions in SPARQL
   (:class:`~wm_store.rdf.SparqlEngine` on rdflib) (``_resolve``).

Processes: a Zenoh router, an echo process (raw baselines), the store and a remote replica are
children of this script (``--role``, ``_children``), started with ``sys.executable``, listening
or connecting on 127.0.0.1 only (free port, multicast scouting off), stopped by PID; temp dirs
are removed. ``_bench`` holds the plan (full or quick) and the run's context, ``_report`` the
tables, ``_run`` the phases in order and the command line.
"""

from benchmarks.wm._bench import FULL, QUICK, Plan
from benchmarks.wm._run import main, run

__all__ = ["FULL", "QUICK", "Plan", "main", "run"]
