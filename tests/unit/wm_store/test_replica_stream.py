"""How a replica applies its change stream: the next change at once, every change once and in
order, and nothing applied while a pull or a reload is under way."""

from __future__ import annotations

import anyio
import pytest

from tests.unit.wm_store.stores import running
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Transact
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


async def test_a_burst_is_applied_once_each_in_order(ontology: Ontology) -> None:
    async with running(WmStore(ontology)) as store:
        transport = InMemoryTransport(WmService(store))
        async with WmClient.connect(transport, ontology) as wm:
            seen: list[int] = []
            wm.on_change(lambda change: seen.append(change.revision))
            first = wm.revision + 1
            for n in range(200):  # committed back to back, the replica catches up after
                await store.transact(Transact(ops=[AddElement(type="Location", label=f"l{n}")]))
            with anyio.fail_after(10):
                await wm.wait_for_revision(store.revision)
            assert seen == list(range(first, store.revision + 1))
            assert wm.replica.statistics().applied == 200
            assert wm.replica.state.to_snapshot() == store.snapshot()


async def test_no_change_is_applied_while_a_pull_is_under_way(ontology: Ontology) -> None:
    """The lock a pull or a reload holds keeps the stream's next change waiting (applied
    after it, through the same checks), even though that change follows the revision."""
    async with running(WmStore(ontology)) as store:
        transport = InMemoryTransport(WmService(store))
        async with WmClient.connect(transport, ontology) as wm:
            before = wm.revision
            async with wm.replica._lock:  # what a pull holds while it awaits the store
                await store.transact(Transact(ops=[AddElement(type="Location", label="x")]))
                for _ in range(20):  # the stream has delivered it; the loop turned over
                    await anyio.lowlevel.checkpoint()
                assert wm.revision == before
            with anyio.fail_after(10):
                await wm.wait_for_revision(before + 1)
            assert wm.resolve_element(label="x")
            assert wm.replica.statistics().applied == 1
