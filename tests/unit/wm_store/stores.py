"""Test helper: a store serving in a task group for the duration of a ``with`` block."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio

from wm_store.server import WmStore

__all__ = ["running"]


@asynccontextmanager
async def running(store: WmStore) -> AsyncIterator[WmStore]:
    """Run ``store`` until the block ends, then close it (its log and snapshots)."""
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        yield store
        tg.cancel_scope.cancel()
    await store.aclose()
