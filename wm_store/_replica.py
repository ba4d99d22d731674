"""The client's local replica of the world model.

The replica subscribes to the change stream *first*, then loads a snapshot, then applies every
change whose revision follows its own. A change that skips revisions is a gap (a message lost,
a subscriber that joined late, a store restart): the replica asks for ``changes-since`` its
revision and, if the store no longer keeps them, reloads a snapshot. Changes it already has are
ignored, so nothing is applied twice and nothing is lost.

A gap at the very end of a burst is invisible until the next change arrives; whoever waits
for a revision (:meth:`Replica.wait_for_revision`) therefore pulls the missing changes itself
if they do not arrive within ``catch_up_after`` seconds.
"""

from __future__ import annotations

import logging
import math
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

import anyio
import msgspec
from anyio.abc import TaskStatus
from anyio.streams.memory import MemoryObjectSendStream

from wm_store._errors import HistoryCompactedError, RevisionTimeoutError
from wm_store._transport import WmTransport, raise_for_error
from wm_store.ontology import Ontology, replay
from wm_store.protocol import (
    Change,
    ChangesReply,
    ChangesSince,
    ClassDefined,
    GetOntology,
    OntologyReply,
    Snapshot,
    SnapshotReply,
    TemplateDefined,
    TermsDefined,
)
from wm_store.scene import SceneState

__all__ = ["Replica", "ReplicaStats"]

_log = logging.getLogger(__name__)


class ReplicaStats(msgspec.Struct, frozen=True):
    revision: int
    applied: int
    gaps: int
    snapshots: int


class Replica:
    """Snapshot + change stream -> a :class:`~wm_store.scene.SceneState` kept current."""

    def __init__(
        self,
        transport: WmTransport,
        base_ontology: Ontology | None = None,
        *,
        timeout: float = 5.0,
        catch_up_after: float = 0.5,
    ) -> None:
        self.transport = transport
        self._own_base = base_ontology is not None
        self.base_ontology = base_ontology or Ontology.default()
        """The core the store's ontology log is replayed on: the store's own core (this
        process's core file when the digests agree, else fetched), or the one given."""
        self.ontology = self.base_ontology
        self.timeout = timeout
        self.catch_up_after = catch_up_after
        self.state = SceneState()
        self._spatial = frozenset(n for n, r in self.base_ontology.relations.items() if r.spatial)
        self.state.set_spatial_predicates(self._spatial)
        self._lock = anyio.Lock()
        self._waiters: dict[int, anyio.Event] = {}
        """One event per awaited revision, set once the replica reaches it: a writer waiting
        for its revision wakes once, not on every change."""
        self._callbacks: list[Callable[[Change], None]] = []
        self._streams: list[MemoryObjectSendStream[Change]] = []
        self._applied = 0
        self._gaps = 0
        self._snapshots = 0

    @property
    def revision(self) -> int:
        return self.state.revision

    def statistics(self) -> ReplicaStats:
        return ReplicaStats(self.state.revision, self._applied, self._gaps, self._snapshots)

    # ------------------------------------------------------------------ running

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Follow the store until cancelled; ``started`` once the first snapshot is loaded."""
        async with self.transport.changes() as stream:
            async with self._lock:
                await self._load_snapshot()
            task_status.started()
            async for change in stream:
                async with self._lock:
                    await self._accept(change)

    async def _accept(self, change: Change) -> None:
        if change.revision <= self.state.revision:
            return
        if change.revision != self.state.revision + 1:
            self._gaps += 1
            _log.info("replica gap: at %d, got %d; resyncing", self.state.revision, change.revision)
            await self._pull()
            if change.revision != self.state.revision + 1:
                return
        self._apply(change)

    async def _pull(self) -> None:
        """Fetch every change after our revision (or a snapshot if they are gone)."""
        request = ChangesSince(revision=self.state.revision)
        try:
            reply = raise_for_error(await self.transport.request(request, timeout=self.timeout))
        except HistoryCompactedError:
            await self._load_snapshot()
            return
        assert isinstance(reply, ChangesReply)
        for change in reply.changes:
            if change.revision == self.state.revision + 1:
                self._apply(change)

    async def _load_snapshot(self) -> None:
        reply = raise_for_error(await self.transport.request(Snapshot(), timeout=self.timeout))
        assert isinstance(reply, SnapshotReply)
        if not self._own_base and reply.core_digest not in ("", self.base_ontology.digest):
            await self._fetch_core()
        state = SceneState.from_snapshot(reply, self._spatial)
        self.ontology = await anyio.to_thread.run_sync(
            replay, self.base_ontology, state.ontology_log
        )
        self.state = state
        self._follow_spatial()
        self._snapshots += 1
        self._notify()

    async def _fetch_core(self) -> None:
        """The store runs another core ontology than this process's file: take the store's."""
        reply = raise_for_error(await self.transport.request(GetOntology(), timeout=self.timeout))
        assert isinstance(reply, OntologyReply)
        _log.info("the store's core ontology differs from this process's file; using the store's")
        self.base_ontology = await anyio.to_thread.run_sync(Ontology.load, reply.core)

    def _follow_spatial(self) -> None:
        spatial = frozenset(n for n, r in self.ontology.relations.items() if r.spatial)
        if spatial != self._spatial or spatial != self.state.spatial_predicates:
            self._spatial = spatial
            self.state.set_spatial_predicates(spatial)

    def _apply(self, change: Change) -> None:
        for delta in change.deltas:
            self.state.apply(delta)
            if isinstance(delta, ClassDefined | TemplateDefined | TermsDefined):
                self.ontology = replay(self.ontology, [delta])
                self._follow_spatial()
        self.state.revision = change.revision
        self._applied += 1
        for callback in list(self._callbacks):
            try:
                callback(change)
            except Exception:
                _log.exception("a world-model watch callback failed")
        for stream in list(self._streams):
            stream.send_nowait(change)
        self._notify()

    def _notify(self) -> None:
        if not self._waiters:
            return
        reached = [r for r in self._waiters if r <= self.state.revision]
        for revision in reached:
            self._waiters.pop(revision).set()

    # ------------------------------------------------------------------ waiting and watching

    async def wait_for_revision(self, revision: int, *, timeout: float | None = None) -> None:
        """Return once the replica has applied ``revision`` (read your own writes).

        Raises :class:`~wm_store.RevisionTimeoutError` (a ``TimeoutError``) after
        ``timeout`` seconds (default: the request timeout), naming the revision reached.
        """
        limit = self.timeout if timeout is None else timeout
        try:
            with anyio.fail_after(limit):
                while self.state.revision < revision:
                    event = self._waiters.get(revision)
                    if event is None:
                        event = self._waiters[revision] = anyio.Event()
                    with anyio.move_on_after(self.catch_up_after):
                        await event.wait()
                        continue
                    async with self._lock:
                        if self.state.revision < revision:
                            await self._pull()
        except TimeoutError:
            raise RevisionTimeoutError(
                f"the world model's revision {revision} did not reach this client within "
                f"{limit:g} s (it is at revision {self.state.revision}): the store or the "
                "link to it is slow or down"
            ) from None

    async def sync(self) -> None:
        """Pull any change the stream has not delivered yet."""
        async with self._lock:
            await self._pull()

    def on_change(self, callback: Callable[[Change], None]) -> Callable[[], None]:
        """Call ``callback(change)`` after each applied change; returns the unsubscribe
        function. Callbacks run on the event loop and must be quick."""
        self._callbacks.append(callback)
        return lambda: self._callbacks.remove(callback)

    @asynccontextmanager
    async def watch(self) -> AsyncIterator[AsyncIterator[Change]]:
        """``async with replica.watch() as changes: async for change in changes: ...``"""
        send, receive = anyio.create_memory_object_stream[Change](math.inf)
        self._streams.append(send)
        try:
            async with receive:
                yield receive
        finally:
            self._streams.remove(send)
            send.close()
