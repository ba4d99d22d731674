"""Following the whole mesh into the event log: :class:`EventRecorder`.

It subscribes once to each source (every task's events, every agent's event log and
liveliness, every device's state, the world model's changes), translates each message
(:class:`~._translate.Translator`) and stores the records in batches: at most
``flush_interval`` seconds or ``batch`` records after they arrive, in one SQLite transaction
each, written on a worker thread (the event loop never waits for the disk).

World-model changes are never lost to a restart of the log: it stores the newest revision it
holds, and on start asks the store for every change after it (``ChangesSince``) before it
follows the live ones; a revision seen twice is stored once. Task, run, agent and device
events are live only (a log that was down did not hear them).

A run's entries come from its agent, the step that names the run from the task agent: two
publishers, so a short run's entries may arrive before its step. An entry of a run no task
has named yet is held up to ``tie_grace`` seconds for its step (then stored as it is); a step
that names a run later still tags the run's stored entries in the next batch.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import anyio
import msgspec
from anyio.abc import TaskStatus

from device_drivers.protocol import StateMessage
from meshlink import InvalidKeyError, Mesh
from meshlink.rpc import Decoder, WireError
from skill_agent.client import EventFeed
from task_agent.protocol import decode_event
from wm_store import WmClient, display_name
from wm_store.protocol import Change, ChangesReply, ChangesSince

from ._records import EventRecord
from ._store import EventStore
from ._translate import Translator

__all__ = ["EventRecorder"]

_log = logging.getLogger("skimesh.eventlog")
_states: Decoder[StateMessage] = Decoder(StateMessage, what="device state")


class EventRecorder:
    """Records everything the mesh says into ``store`` (see the module doc)."""

    def __init__(
        self,
        store: EventStore,
        *,
        flush_interval: float = 0.2,
        batch: int = 500,
        tie_grace: float = 1.0,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.store = store
        self.flush_interval = flush_interval
        self.batch = batch
        self.tie_grace = tie_grace
        self.clock = clock
        self.translator = Translator()
        self.last_seq = 0
        self.skipped = 0
        """Messages that could not be decoded (logged, not stored)."""
        self._pending: list[EventRecord] = []
        self._untied: list[tuple[float, EventRecord]] = []
        self._wm_revision = 0
        self._stored_revision = 0
        self._arrived = anyio.Event()
        self._stored = anyio.Event()

    # ------------------------------------------------------------------ intake
    def add(self, record: EventRecord | None) -> None:
        """Queue one record for the next batch (None: nothing to record)."""
        if record is None:
            return
        if record.kind == "run" and record.run and not record.task:
            self._untied.append((anyio.current_time(), record))
        else:
            self._pending.append(record)
        self._arrived.set()

    def add_change(self, change: Change, wm: WmClient | None = None) -> None:
        if change.revision <= self._wm_revision:
            return  # already recorded (history and live overlap)
        self._wm_revision = change.revision
        if wm is None:
            self.add(self.translator.change(change))
        else:
            self.add(self.translator.change(change, lambda i: display_name(wm.find_element(i), i)))

    async def wait_stored(self, after: int) -> None:
        """Return once a record with ``seq > after`` is stored."""
        while self.last_seq <= after:
            await self._stored.wait()

    # ------------------------------------------------------------------ running
    async def run(
        self,
        mesh: Mesh,
        wm: WmClient | None,
        *,
        task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
    ) -> None:
        """Follow ``mesh`` (and ``wm``'s changes, if given) until cancelled; ``started`` once
        every subscription is in place. Pending records are stored when cancelled."""
        info = await anyio.to_thread.run_sync(self.store.info)
        self.last_seq = info.last_seq
        self._wm_revision = self._stored_revision = info.wm_revision
        try:
            async with anyio.create_task_group() as tg:
                for follow in (self._tasks, self._runs, self._agents, self._devices):
                    await tg.start(follow, mesh)
                if wm is not None:
                    await tg.start(self._world_model, wm)
                tg.start_soon(self._flusher)
                task_status.started()
        finally:
            with anyio.CancelScope(shield=True):
                await self.flush(everything=True)

    def _tie(self, everything: bool) -> None:
        """Move held run entries to the batch: those whose task is known now (tagged), and
        those held ``tie_grace`` seconds (or all, with ``everything``)."""
        held, self._untied = self._untied, []
        oldest = anyio.current_time() - self.tie_grace
        for arrived, record in held:
            task = self.translator.task_of(record.run)
            if task:
                self._pending.append(msgspec.structs.replace(record, task=task))
            elif everything or arrived <= oldest:
                self._pending.append(record)
            else:
                self._untied.append((arrived, record))

    async def flush(self, *, everything: bool = False) -> None:
        """Store the queued records now (``everything``: also the held run entries)."""
        self._tie(everything)
        records, self._pending = self._pending, []
        runs, self.translator.learnt = self.translator.learnt, []
        revision = self._wm_revision if self._wm_revision > self._stored_revision else None
        if not records and not runs and revision is None:
            return
        self.last_seq = await anyio.to_thread.run_sync(
            lambda: self.store.append(records, wm_revision=revision, runs=runs)
        )
        if revision is not None:
            self._stored_revision = revision
        self._stored.set()
        self._stored = anyio.Event()

    async def _flusher(self) -> None:
        while True:
            if not self._untied:
                await self._arrived.wait()
            self._arrived = anyio.Event()
            with anyio.move_on_after(self.flush_interval):
                while len(self._pending) < self.batch:
                    await self._arrived.wait()
                    self._arrived = anyio.Event()
            await self.flush()

    async def _subscribed(
        self,
        mesh: Mesh,
        key: str,
        take: Callable[[str, bytes], None],
        task_status: TaskStatus[None],
    ) -> None:
        async with mesh.subscribe(key) as samples:
            task_status.started()
            async for sample in samples:
                if sample.kind != "put":
                    continue
                try:
                    take(sample.key, sample.payload)
                except (WireError, InvalidKeyError) as e:
                    self.skipped += 1
                    _log.warning("skipped a message on %s: %s", sample.key, e)

    async def _tasks(self, mesh: Mesh, *, task_status: TaskStatus[None]) -> None:
        def take(key: str, payload: bytes) -> None:
            self.add(self.translator.task_event(decode_event(payload)))

        await self._subscribed(mesh, mesh.keys.tasks_events(), take, task_status)

    async def _devices(self, mesh: Mesh, *, task_status: TaskStatus[None]) -> None:
        def take(key: str, payload: bytes) -> None:
            robot, device = mesh.keys.device_of_state_key(key)
            message = _states.decode(payload)
            self.add(self.translator.device_state(robot, device, message, self.clock()))

        await self._subscribed(mesh, mesh.keys.devices_state(), take, task_status)

    async def _runs(self, mesh: Mesh, *, task_status: TaskStatus[None]) -> None:
        async with EventFeed.open(mesh) as entries:
            task_status.started()
            async for entry in entries:
                self.add(self.translator.run_entry(entry))

    async def _agents(self, mesh: Mesh, *, task_status: TaskStatus[None]) -> None:
        async with mesh.watch_liveliness(mesh.keys.agents()) as tokens:
            task_status.started()
            async for token in tokens:
                try:
                    agent = mesh.keys.name_of_agent_key(token.key)
                except InvalidKeyError:
                    continue
                self.add(self.translator.liveliness(agent, token.alive, self.clock()))

    async def _world_model(self, wm: WmClient, *, task_status: TaskStatus[None]) -> None:
        async with wm.watch() as changes:
            await _backfill(wm, self._wm_revision, lambda c: self.add_change(c, wm))
            task_status.started()
            async for change in changes:
                self.add_change(change, wm)


async def _backfill(
    wm: WmClient, revision: int, take: Callable[[Change], None], *, page: int = 1000
) -> None:
    """Every change after ``revision`` the store still has, in order, ``page`` at a time."""
    while True:
        reply = await wm.request(ChangesSince(revision=revision, limit=page))
        assert isinstance(reply, ChangesReply)
        if not reply.changes:
            return
        if reply.changes[0].revision > revision + 1:
            _log.warning(
                "the store no longer has revisions %d..%d: the log has a gap there",
                revision + 1,
                reply.changes[0].revision - 1,
            )
        for change in reply.changes:
            take(change)
        revision = reply.changes[-1].revision
