"""Shared-space benchmark: what reserving a place adds to a ``navigate``.

    python -m benchmarks.space               # full run (400 drives each way)
    python -m benchmarks.space --quick       # 60 drives each way
    python -m benchmarks.space --json out.json

Figure (run times, method and results: ``docs/benchmarks.md``, section "Shared space"): the
time of one ``navigate`` run (``AgentCore.start`` to its result) with the reservation
(``Navigate``: a compare-and-set on the goal's ``reservedBy`` before the base moves, one
write; the release of the start rides in the write that records the base's report) beside
the same skill without it (a subclass whose ``take_room`` / ``leave_start`` do nothing),
alternating run by run in one process so both see the same load; p50 and p99, and the
median of the per-pair differences against the target (< 5 ms).

Set-up, all in this process on 127.0.0.1 (free port, multicast off): a Zenoh router, the
world-model store (in memory: no fsync; what a durable store's fsync costs per write is in
the world-model benchmark) served over Zenoh, a world-model client on its own session with
the kitting scenario's scene, and r1's agent core with an instant base (``go_to`` returns at
once at its target), driving Station-1 -> Station-2 -> Station-1 ... Each ``navigate`` commits
its base's report and its effects either way; the reservation adds one write.
"""

from benchmarks.space._run import main

__all__ = ["main"]
