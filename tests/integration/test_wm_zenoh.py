"""The world model over real Zenoh on loopback: a store process, writer processes, replicas.

Covers: concurrent compare-and-set writers in two processes, replica convergence across
processes, gap detection and resync, storage-style reads, SIGKILL of the store in the middle of
a write burst and restart with every acknowledged transaction.
"""

from __future__ import annotations

import hashlib
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import TypeVar

import anyio
import msgspec
import pytest

from meshlink import MeshConfig, open_mesh
from wm_store import WmClient, ZenohTransport
from wm_store.protocol import AddElement, Change, Element, encode

from .procs import Child, start_store, start_worker

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]

T = TypeVar("T")


def digest(wm: WmClient) -> str:
    snap = wm.replica.state.to_snapshot()
    snap.elements.sort(key=lambda e: e.id)
    snap.relations.sort(key=lambda r: (r.subject, r.predicate, r.object))
    return hashlib.sha256(msgspec.msgpack.encode(snap)).hexdigest()


@asynccontextmanager
async def client(endpoint: str, mesh: str) -> AsyncIterator[WmClient]:
    async with (
        open_mesh(MeshConfig(connect=(endpoint,), mesh=mesh)) as session,
        WmClient.connect(ZenohTransport(session), author="test") as wm,
    ):
        yield wm


def with_client(endpoint: str, mesh: str, body: Callable[[WmClient], Awaitable[T]]) -> T:
    async def main() -> T:
        async with client(endpoint, mesh) as wm:
            return await body(wm)

    return anyio.run(main)


def test_cas_writers_in_two_processes_converge(
    router_endpoint: str, tmp_path: Path, mesh_name: str
) -> None:
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    workers: list[Child] = []
    try:

        async def setup(wm: WmClient) -> str:
            return await wm.add_element("Box", label="counter", properties={"capacity": 0})

        counter = with_client(router_endpoint, mesh_name, setup)
        workers = [start_worker("cas", router_endpoint, mesh_name, f"w{i}", 40) for i in range(2)]
        for w in workers:
            w.expect(lambda m: "conflicts" in m, timeout=60)

        async def final(wm: WmClient) -> tuple[int, str, int]:
            info = await wm.info()
            await wm.wait_for_revision(info.revision)
            value = wm.get_element(counter).properties["capacity"]
            assert isinstance(value, int)
            return info.revision, digest(wm), value

        revision, expected, value = with_client(router_endpoint, mesh_name, final)
        assert value == 80, "every compare-and-set increment counted exactly once"
        for w in workers:
            w.send(str(revision))
            reply = w.expect(lambda m: "digest" in m)
            assert reply["revision"] == revision
            assert reply["digest"] == expected, "replicas in other processes converge"
    finally:
        for w in workers:
            w.stop()
        store.stop()


def test_sigkill_during_burst_loses_no_acknowledged_transaction(
    router_endpoint: str, tmp_path: Path, mesh_name: str
) -> None:
    data = tmp_path / "wm"
    store = start_store(router_endpoint, mesh_name, data)
    workers = [
        start_worker("burst", router_endpoint, mesh_name, f"w{i}", 100_000) for i in range(2)
    ]
    acked: set[str] = set()
    try:
        while len(acked) < 400:
            for w in workers:
                msg = w.expect(lambda m: "ack" in m)
                acked.add(msg["ack"])
        store.kill()  # SIGKILL in the middle of the burst
        for w in workers:
            w.close_stdin()
            while (tail := w.next_json(timeout=30)) is not None:
                if "ack" in tail:
                    acked.add(tail["ack"])
        store = start_store(router_endpoint, mesh_name, data)

        async def check(wm: WmClient) -> list[Element]:
            return wm.resolve_element(type="Gear")

        gears = with_client(router_endpoint, mesh_name, check)
        labels = [g.label for g in gears]
        assert len(labels) == len(set(labels)), "no transaction applied twice"
        missing = acked - set(labels)
        assert not missing, f"acknowledged but lost after SIGKILL: {sorted(missing)[:5]}"
        extra = set(labels) - acked
        assert len(extra) <= len(workers), (
            "only in-flight (unacknowledged) transactions may add to it"
        )
        for label in extra:
            name, _, index = label.rpartition("-")
            assert name in {"w0", "w1"} and index.isdigit(), f"garbage element {label!r}"
    finally:
        for w in workers:
            w.stop()
        store.stop()


class DroppingTransport(ZenohTransport):
    """Drops some revisions from the change stream, as a lossy link would."""

    def __init__(self, *args: object, drop: set[int]) -> None:
        super().__init__(*args)  # type: ignore[arg-type]
        self.drop = drop

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        async with super().changes() as stream:

            async def filtered() -> AsyncIterator[Change]:
                async for change in stream:
                    if change.revision not in self.drop:
                        yield change

            yield filtered()


def test_replica_detects_gaps_and_resyncs(
    router_endpoint: str, tmp_path: Path, mesh_name: str
) -> None:
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    try:

        async def main() -> None:
            config = MeshConfig(connect=(router_endpoint,), mesh=mesh_name)
            async with (
                open_mesh(config) as s1,
                open_mesh(config) as s2,
                WmClient.connect(DroppingTransport(s1, drop={2, 3, 7})) as lossy,
                WmClient.connect(ZenohTransport(s2)) as writer,
            ):
                for i in range(8):
                    await writer.add_element("Gear", f"g{i}")
                await lossy.wait_for_revision(writer.revision)
                assert lossy.replica.statistics().gaps >= 1
                assert digest(lossy) == digest(writer)
                # A change from the future (as after a missed burst) triggers a resync too,
                # and is not applied on its own.
                forged = Change(revision=writer.revision + 5, deltas=[], stamp=0.0)
                s2.put(s2.keys.wm_changes(), encode(forged))
                await writer.add_element("Gear", "after")
                await lossy.wait_for_revision(writer.revision)
                assert digest(lossy) == digest(writer)

        anyio.run(main)
    finally:
        store.stop()


def test_any_zenoh_tool_can_read_elements(
    router_endpoint: str, tmp_path: Path, mesh_name: str
) -> None:
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    try:

        async def main() -> None:
            async with client(router_endpoint, mesh_name) as wm:
                await wm.transact(
                    [AddElement(type="Gear", label="g"), AddElement(type="Shaft", label="s")]
                )
                session = wm.transport.mesh  # type: ignore[attr-defined]
                replies = await session.get(session.keys.wm_elements())
                got = {
                    r.key.rsplit("/", 1)[-1]: msgspec.json.decode(r.payload, type=Element)
                    for r in replies
                }
                assert sorted(got) == ["Gear-1", "Shaft-1"]
                assert got["Gear-1"].label == "g"
                one = await session.get(session.keys.wm_element("Shaft-1"))
                assert [r.key for r in one] == [session.keys.wm_element("Shaft-1")]

        anyio.run(main)
    finally:
        assert store.stop() == 0, store.log()
