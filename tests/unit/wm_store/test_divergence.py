"""A replica never diverges silently: a change that did not come from the store (a forged
publication on an open mesh) is found and the replica reloads, whether the store's real change
at that revision follows it or nothing follows it."""

from __future__ import annotations

import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest
from anyio.streams.memory import MemoryObjectSendStream

from tests.unit.wm_store.stores import running
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Change, Element, ElementPut, Transact
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


class ForgeableTransport(InMemoryTransport):
    """The store's change stream, plus whatever an attacker publishes on it (``forge``)."""

    def __init__(self, service: WmService) -> None:
        super().__init__(service)
        self.forged: MemoryObjectSendStream[Change] | None = None

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        send, receive = anyio.create_memory_object_stream[Change](100)
        self.forged = send
        async with send, receive, super().changes() as real, anyio.create_task_group() as tg:

            async def pump() -> None:
                async for change in real:
                    await send.send(change)

            tg.start_soon(pump)
            yield receive
            tg.cancel_scope.cancel()

    async def forge(self, revision: int, label: str) -> None:
        element = Element(id=f"Gear-{900 + revision}", type="Gear", label=label)
        change = Change(
            revision=revision, deltas=[ElementPut(element)], stamp=time.time(), digest="f"
        )
        assert self.forged is not None
        await self.forged.send(change)


async def test_a_forged_change_then_the_real_one_at_that_revision() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s:
        transport = ForgeableTransport(WmService(s))
        async with WmClient.connect(transport, author="a") as wm:
            await transport.forge(s.revision + 1, "forged")
            with anyio.fail_after(10):
                await wm.wait_for_revision(s.revision + 1)
            assert wm.resolve_element(type="Gear", label="forged"), "the replica applied it"
            await s.transact(Transact(ops=[AddElement(type="Box", label="real")]))
            with anyio.fail_after(10):
                await wm.replica.wait_for_snapshot(2)  # the first at start, one more
            assert wm.replica.divergences == 1
            assert wm.resolve_element(type="Box", label="real")
            assert not wm.resolve_element(type="Gear", label="forged")
            assert wm.replica.state.to_snapshot() == s.snapshot()


async def test_a_forged_change_and_nothing_after_it() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s:
        transport = ForgeableTransport(WmService(s))
        async with WmClient.connect(transport, author="a") as wm:
            wm.replica.check_every = 0.05  # the periodic check finds it; no real change follows
            await transport.forge(s.revision + 1, "forged")
            with anyio.fail_after(10):
                await wm.replica.wait_for_snapshot(2)
            assert wm.replica.divergences == 1
            assert not wm.resolve_element(type="Gear", label="forged")
            assert wm.revision == s.revision
