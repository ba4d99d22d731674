"""What one replica pays per change: the changes of a fleet run replayed into a fresh replica.

The changes a 50-robot run committed (as the store published them, MessagePack bytes) are
replayed into a :class:`~wm_store.Replica` that starts from the store's snapshot at the
revision before them, through a transport that hands it the recorded payloads: per change,
the decode, the replica's bookkeeping (lock, revision and digest, waiters) and the scene's
apply and indexes; then again with ``listeners`` on-change callbacks that re-evaluate a
navigate-like hold condition each (what a run with hold-conditions does), and the whole replay
under :mod:`cProfile` for where the time goes. The Zenoh receive (a sample handed from Zenoh's
thread to the loop) is not in it: the world-model benchmark measures the change path over
Zenoh (``python -m benchmarks.wm``).
"""

from __future__ import annotations

import cProfile
import io
import pstats
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager

import msgspec

from skill_agent.conditions import evaluate_all
from skill_agent.protocol import RelationCond
from wm_store import Replica, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import Change, Reply, Request, Snapshot, SnapshotReply, decode_change

__all__ = ["ReplayCost", "replay_cost"]


class ReplayCost(msgspec.Struct, kw_only=True):
    changes: int
    decode_us: float
    """Decoding one change (µs)."""
    replica_us: float
    """Decode + replica bookkeeping + apply and indexes, per change (µs)."""
    listener_us: float
    """The same with ``listeners`` hold-condition callbacks, per change (µs)."""
    listeners: int
    profile: str
    """The top functions of the replay with listeners, by own time."""


class _Replay:
    """A transport replaying recorded changes after a recorded snapshot."""

    def __init__(self, snapshot: SnapshotReply, payloads: list[bytes]) -> None:
        self.snapshot = snapshot
        self.payloads = payloads
        self.began = 0.0
        """CPU time when the first change was handed over (the snapshot loaded)."""

    async def request(self, request: Request, *, timeout: float) -> Reply:
        assert isinstance(request, Snapshot)
        return self.snapshot

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        async def stream() -> AsyncIterator[Change]:
            self.began = time.process_time()
            for payload in self.payloads:
                yield decode_change(payload)

        yield stream()


async def _replay(
    ontology: Ontology,
    snapshot: SnapshotReply,
    payloads: list[bytes],
    listeners: int,
    bind: dict[str, str],
) -> float:
    """Seconds of CPU to replay every payload into a fresh replica (its snapshot loaded)."""
    transport = _Replay(snapshot, payloads)
    replica = Replica(transport, ontology, check_every=0)
    view = WmClient(transport, replica=replica)
    hold = [RelationCond(subject="robot", predicate="at", object="start")]

    def check(_change: Change) -> None:
        evaluate_all(hold, view, dict(bind))

    for _ in range(listeners):
        replica.on_change(check)
    await replica.run()
    return time.process_time() - transport.began


async def replay_cost(
    ontology: Ontology,
    store_request: Callable[..., Awaitable[Reply]],
    revision: int,
    payloads: list[bytes],
    bind: dict[str, str],
    *,
    listeners: int = 1,
) -> ReplayCost:
    """Replay ``payloads`` (the changes after ``revision``) as described in the module doc.
    ``store_request``: the store's ``request`` (a transport's) for the snapshot at
    ``revision``; ``bind``: the hold condition's parameters (``robot``, ``start``)."""
    reply = await store_request(Snapshot(revision=revision), timeout=30.0)
    assert isinstance(reply, SnapshotReply)
    n = len(payloads)
    began = time.process_time()
    for payload in payloads:
        decode_change(payload)
    decode = time.process_time() - began
    bare = min([await _replay(ontology, reply, payloads, 0, bind) for _ in range(3)])
    with_listeners = min(
        [await _replay(ontology, reply, payloads, listeners, bind) for _ in range(3)]
    )
    profiler = cProfile.Profile()
    profiler.enable()
    await _replay(ontology, reply, payloads, listeners, bind)
    profiler.disable()
    out = io.StringIO()
    pstats.Stats(profiler, stream=out).sort_stats("tottime").print_stats(14)
    return ReplayCost(
        changes=n,
        decode_us=decode / n * 1e6,
        replica_us=bare / n * 1e6,
        listener_us=with_listeners / n * 1e6,
        listeners=listeners,
        profile=out.getvalue(),
    )
