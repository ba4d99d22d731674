"""Test helper: a store serving in a task group for the duration of a ``with`` block."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio

from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.server import WmService, WmStore

__all__ = ["memory_client", "running", "serving"]


@asynccontextmanager
async def running(store: WmStore) -> AsyncIterator[WmStore]:
    """Run ``store`` until the block ends, then close it (its log and snapshots)."""
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        yield store
        tg.cancel_scope.cancel()
    await store.aclose()


@asynccontextmanager
async def memory_client() -> AsyncIterator[WmClient]:
    """A client of a fresh in-memory store (core ontology) over the in-memory transport."""
    store = await WmStore.open(Ontology.default())
    async with running(store), WmClient.connect(InMemoryTransport(WmService(store))) as client:
        yield client


@asynccontextmanager
async def serving(store: WmStore) -> AsyncIterator[tuple[WmStore, WmService]]:
    """Run ``store`` with a :class:`WmService` on it until the block ends; the service is
    closed first (its SPARQL worker's child ended)."""
    async with running(store) as s:
        service = WmService(s)
        try:
            yield s, service
        finally:
            await service.aclose()
