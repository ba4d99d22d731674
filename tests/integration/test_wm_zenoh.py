"""The world model over real Zenoh on loopback: a store process, writer processes, replicas.

Covers: concurrent compare-and-set writers in two processes, replica convergence across
processes, gap detection and resync, storage-style reads, SIGKILL of the store in the middle of
a write burst and restart with every acknowledged transaction, classes and templates taught at
run time reaching replicas in other processes and surviving a SIGKILL of the store; and that
the world-model benchmark's smoke run (``benchmarks.wm --quick``) completes (timing figures
are its business, not a test's: nothing here asserts one).
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import TypeVar

import anyio
import msgspec
import pytest

from meshlink import MeshConfig, open_mesh
from meshlink.rpc import encode
from wm_store import WmClient, ZenohTransport
from wm_store.protocol import AddElement, Change, Element, ElementPut, TemplateDef

from .procs import ROOT, Child, start_store, start_worker

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


def test_a_forged_change_on_an_open_mesh_is_found_and_the_real_one_applied(
    router_endpoint: str, tmp_path: Path, mesh_name: str
) -> None:
    """Anyone on an open mesh can publish on ``wm/changes``: a replica that applied a forged
    change at the next revision finds it when the store's real change of that revision comes
    (another digest), reloads, and holds the real one."""
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    try:

        async def main() -> None:
            config = MeshConfig(connect=(router_endpoint,), mesh=mesh_name)
            async with (
                open_mesh(config) as s1,
                open_mesh(config) as s2,
                WmClient.connect(ZenohTransport(s1)) as replica,
                WmClient.connect(ZenohTransport(s2)) as writer,
            ):
                await writer.add_element("Gear", "before")
                await replica.wait_for_revision(writer.revision)
                fake = Element(id="Gear-99", type="Gear", label="forged")
                forged = Change(
                    revision=writer.revision + 1, deltas=[ElementPut(fake)], stamp=0.0, digest="x"
                )
                s2.put(s2.keys.wm_changes(), encode(forged))
                with anyio.fail_after(10):
                    await replica.wait_for_revision(writer.revision + 1)
                assert replica.find_element("Gear-99") is not None, "applied: it looked real"
                real = await writer.add_element("Box", "real")
                real_revision = writer.revision
                with anyio.fail_after(10):  # both replicas got the forgery: both reload
                    for wm in (replica, writer):
                        await wm.replica.wait_for_snapshot(2)
                        await wm.wait_for_revision(real_revision)
                assert replica.find_element("Gear-99") is None
                assert replica.find_element(real) is not None
                assert digest(replica) == digest(writer)

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


def test_taught_class_reaches_other_processes_and_survives_a_store_kill(
    router_endpoint: str, tmp_path: Path, mesh_name: str
) -> None:
    data = tmp_path / "wm"
    store = start_store(router_endpoint, mesh_name, data)
    followers = [start_worker("follow", router_endpoint, mesh_name, "early", 0)]
    try:

        async def teach(wm: WmClient) -> int:
            await wm.define_class("Sprocket", "Gear")
            small = TemplateDef(name="small-sprocket", type="Sprocket", properties={"mass": 0.05})
            await wm.define_template(small)
            await wm.add_element("Sprocket", "s1")
            return wm.revision

        revision = with_client(router_endpoint, mesh_name, teach)
        taught = {
            "classes": {"Sprocket": ["Sprocket", "Gear", "Part", "PhysicalObject"]},
            "templates": {"small-sprocket": "Sprocket"},
        }
        followers[0].send(str(revision))
        live = followers[0].expect(lambda m: "digest" in m)
        assert live["revision"] == revision
        assert {k: live[k] for k in taught} == taught, "the change extended a remote ontology"

        store.kill()  # SIGKILL: no final snapshot, the restart replays the log
        store = start_store(router_endpoint, mesh_name, data)
        followers.append(start_worker("follow", router_endpoint, mesh_name, "late", 0))
        followers[1].send(str(revision))
        late = followers[1].expect(lambda m: "digest" in m)
        assert {k: late[k] for k in taught} == taught, "the restarted store still knows them"
        assert (late["revision"], late["digest"]) == (revision, live["digest"])
    finally:
        for f in followers:
            f.stop()
        store.stop()


@pytest.mark.timeout(420)
def test_benchmark_quick_run_completes(tmp_path: Path) -> None:
    out = tmp_path / "wm.json"
    command = [sys.executable, "-m", "benchmarks.wm", "--quick", "--json", str(out)]
    command += ["--data-root", str(tmp_path)]
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=400)
    assert result.returncode == 0, result.stderr[-4000:]
    header = "figure | value | baseline (same run) | ratio | target | met?"
    assert header in " ".join(result.stdout.split()), result.stdout[:2000]
    for figure in (
        "durable tx/s, group commit, in-process, 16 writer(s)",
        "durable tx/s, group, via Zenoh (WmClient), 16 writer(s)",
        "change propagation p50 (store publish -> remote on_change)",
        "resolve p50, 10k elements: label (unique)",
    ):
        assert figure in result.stdout
    results = json.loads(out.read_text())
    assert results["plan"]["rounds"] == 1, "the quick plan ran"
    assert results["details"]["elements"] == 10_000
    assert [q["agree"] for q in results["details"]["resolve"]] == [True, True, True], (
        "resolve and SPARQL give the same answers"
    )
    assert list(tmp_path.iterdir()) == [out], "the benchmark removed its data directories"
