"""The world-model benchmark's child processes (``python -m benchmarks.wm --role ...``): the
echo process (raw baselines), the store process and the remote replica."""

from __future__ import annotations

import argparse
import json
import struct
import threading
import time

import anyio
import zenoh

from benchmarks.common import (
    emit,
    stdin_lines,
)
from benchmarks.wm._bench import PAYLOAD, now_ns, raw_keys
from meshlink import Answer, IncomingQuery, MeshConfig, open_mesh
from meshlink.testing import undeclare
from skimesh.runtime import run_service
from wm_store import WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.server import StoreConfig, WmStore, serve_store


def child_echo(args: argparse.Namespace) -> int:
    """Raw Zenoh queryable (200-byte reply) and subscriber (one-way times), plus a meshlink
    queryable, all on one client session."""
    rtt_key, oneway_key, bridge_key = raw_keys(args.mesh)
    reply = bytes(PAYLOAD)
    delays: list[int] = []
    arrived = threading.Condition()

    def on_query(query: zenoh.Query) -> None:  # zenoh's thread for this queryable
        with query:
            query.reply(query.key_expr, reply)

    def on_sample(sample: zenoh.Sample) -> None:
        now = time.monotonic_ns()
        (sent,) = struct.unpack_from("<q", sample.payload.to_bytes())
        with arrived:
            delays.append(now - sent)
            arrived.notify_all()

    async def bridge_echo(query: IncomingQuery) -> list[Answer]:
        return [Answer(key=bridge_key, payload=reply)]

    def wait_for(count: int) -> list[int]:
        with arrived:
            arrived.wait_for(lambda: len(delays) >= count, timeout=10.0)
            got = list(delays)
            delays.clear()
            return got

    async def main() -> int:
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            queryable = mesh.session.declare_queryable(rtt_key, on_query)
            subscriber = mesh.session.declare_subscriber(oneway_key, on_sample)
            try:
                await tg.start(mesh.serve, bridge_key, bridge_echo)  # also syncs with the router
                emit({"ready": True})
                async for line in stdin_lines():
                    command = json.loads(line)
                    got = await anyio.to_thread.run_sync(wait_for, command["expect"])
                    emit({"oneway": got[command["skip"] :], "received": len(got)})
            finally:
                undeclare(subscriber)
                undeclare(queryable)
                tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def child_store(args: argparse.Namespace) -> int:
    """``skimesh wm`` (WmStore + serve_store), plus a listener that stamps each change with
    CLOCK_MONOTONIC just before the server's own listener publishes it."""
    published: list[tuple[int, int, int]] = []

    async def main() -> int:
        config = StoreConfig(data_dir=args.data, durability=args.durability)
        store = await WmStore.open(Ontology.default(), config)
        store.add_listener(
            lambda c, payload: published.append((c.revision, now_ns(), len(payload)))
        )
        mesh_config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(mesh_config) as mesh, anyio.create_task_group() as tg:
            await tg.start(serve_store, mesh, store)
            emit({"ready": store.revision})
            async for line in stdin_lines():
                after = json.loads(line)["after"]
                emit({"stamps": [p for p in published if p[0] > after]})
            tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def child_replica(args: argparse.Namespace) -> int:
    """A WmClient whose ``on_change`` stamps each applied change with CLOCK_MONOTONIC."""
    applied: list[tuple[int, int]] = []

    async def main() -> int:
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
            wm.on_change(lambda change: applied.append((change.revision, now_ns())))
            emit({"ready": wm.revision})
            async for line in stdin_lines():
                command = json.loads(line)
                await wm.wait_for_revision(command["until"], timeout=30.0)
                emit({"stamps": [a for a in applied if a[0] > command["after"]]})
        return 0

    return run_service(main)
