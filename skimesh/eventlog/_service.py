"""Serving the site event log: :func:`serve_event_log` (records and answers queries).

The log answers on ``eventlog/rpc`` (read-only: :class:`~._records.QueryEvents`,
:class:`~._records.LogInfo`) through the one RPC layer, with its file read on a worker thread.
A query with ``wait`` that finds nothing waits for the next stored record (a long poll), so
``skimesh events --follow`` needs no polling interval.
"""

from __future__ import annotations

import logging
from pathlib import Path

import anyio
from anyio.abc import TaskStatus

from meshlink import Mesh
from meshlink.rpc import RequestHandler
from wm_store import WmClient, ZenohTransport

from ._errors import EventLogError
from ._recorder import EventRecorder
from ._records import EventsReply, LogInfo, LogReply, LogRequest, QueryEvents
from ._store import EventStore

__all__ = ["EventLogService", "serve_event_log"]

_log = logging.getLogger("skimesh.eventlog")


class EventLogService:
    """Answers the log's requests from ``store``; follows ``recorder`` for long polls."""

    def __init__(self, store: EventStore, recorder: EventRecorder) -> None:
        self.store, self.recorder = store, recorder
        self.rpc: RequestHandler[LogRequest, LogReply] = RequestHandler(
            LogRequest, self.handle, name="eventlog/rpc"
        )

    async def handle(self, request: LogRequest) -> LogReply:
        if isinstance(request, LogInfo):
            return await anyio.to_thread.run_sync(self.store.info)
        return await self._query(request)

    async def _query(self, q: QueryEvents) -> EventsReply:
        def read() -> EventsReply:
            records = self.store.query(q.filter, after=q.after, limit=q.limit + 1)
            return EventsReply(
                records=records[: q.limit],
                last_seq=self.recorder.last_seq,
                more=len(records) > q.limit,
            )

        reply = await anyio.to_thread.run_sync(read)
        deadline = anyio.current_time() + q.wait
        after = max(q.after, reply.last_seq)
        while not reply.records and anyio.current_time() < deadline:
            with anyio.move_on_after(deadline - anyio.current_time()):
                await self.recorder.wait_stored(after)
            after = self.recorder.last_seq
            reply = await anyio.to_thread.run_sync(read)
        return reply


async def serve_event_log(
    mesh: Mesh,
    path: str | Path,
    *,
    world_model: bool = True,
    wm_timeout: float = 10.0,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Keep the site event log in the SQLite file ``path`` until cancelled: follow the mesh
    (with ``world_model``, also the store's changes, backfilled from the log's newest revision)
    and serve ``eventlog/rpc``. ``started`` once recording and serving.

    Raises:
        EventLogError: the file is no event log, or the world model did not answer.
    """
    store = EventStore(path)
    try:
        recorder = EventRecorder(store)
        service = EventLogService(store, recorder)
        async with anyio.create_task_group() as tg:
            wm: WmClient | None = None
            if world_model:
                wm = await _connect(tg, mesh, wm_timeout)
            await tg.start(recorder.run, mesh, wm)
            key = mesh.keys.eventlog_rpc()
            await tg.start(mesh.serve, key, service.rpc.serve_on(key))
            info = await anyio.to_thread.run_sync(store.info)
            _log.info(  # "event log ready" is the command's line (shown without -v)
                "event log %s: %d records, world model to revision %d",
                store.path,
                info.count,
                info.wm_revision,
            )
            task_status.started()
    finally:
        store.close()


async def _connect(tg: anyio.abc.TaskGroup, mesh: Mesh, timeout: float) -> WmClient:
    """A world-model client living as long as ``tg`` (closed when it is cancelled)."""

    async def hold(*, task_status: TaskStatus[WmClient]) -> None:
        async with WmClient.connect(ZenohTransport(mesh), timeout=timeout) as wm:
            task_status.started(wm)
            await anyio.sleep_forever()

    try:
        client: WmClient = await tg.start(hold)
    except Exception as e:  # the store's own errors name what went wrong
        raise EventLogError(f"the event log cannot follow the world model: {e}") from e
    return client
