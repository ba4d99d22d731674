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
from typing import TYPE_CHECKING

import anyio
import msgspec
from anyio.abc import TaskStatus
from anyio.streams.memory import MemoryObjectSendStream

from wm_store import ontology as onto  # a lazy face: rdflib loads with the first ontology
from wm_store._errors import HistoryCompactedError, RevisionTimeoutError, WmError
from wm_store._transport import WmTransport, raise_for_error
from wm_store.protocol import (
    Change,
    ChangesReply,
    ChangesSince,
    ClassDefined,
    GetOntology,
    Info,
    InfoReply,
    OntologyReply,
    Snapshot,
    SnapshotReply,
    TemplateDefined,
    TermsDefined,
)
from wm_store.scene import SceneState

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["Replica", "ReplicaStats"]

_log = logging.getLogger(__name__)

_RECENT = 1024
"""How many digests of applied changes a replica keeps to compare with the store's."""


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
        check_every: float = 5.0,
    ) -> None:
        self.transport = transport
        self.check_every = check_every
        """Seconds between two checks of this replica against the store (revision and digest;
        0: never)."""
        self._own_base = base_ontology is not None
        self.base_ontology = base_ontology or onto.Ontology.default()
        """The core the store's ontology log is replayed on: the store's own core (this
        process's core file when the digests agree, else fetched), or the one given."""
        self.ontology = self.base_ontology
        self.timeout = timeout
        self.catch_up_after = catch_up_after
        self.state = SceneState()
        self._spatial = frozenset(n for n, r in self.base_ontology.relations.items() if r.spatial)
        self.state.set_spatial_predicates(self._spatial)
        self._lock = anyio.Lock(fast_acquire=True)
        """Held while a change is pulled or a snapshot reloaded (they await the store); the
        next change of the stream is applied without it when it is free (:meth:`_next`).
        Taken without a pass through the loop when free: the change stream yields to the
        loop often enough, and a pass per change would cost every replica a loop wake-up
        per change."""
        self._waiters: dict[int, anyio.Event] = {}
        """One event per awaited revision, set once the replica reaches it: a writer waiting
        for its revision wakes once, not on every change."""
        self._callbacks: list[Callable[[Change], None]] = []
        self._streams: list[MemoryObjectSendStream[Change]] = []
        self._applied = 0
        self._gaps = 0
        self._snapshots = 0
        self._recent: dict[int, str] = {}
        """The digests of the changes applied lately, by revision (the last :data:`_RECENT`)."""
        self.divergences = 0
        """How many times the replica found it had applied what the store never committed."""
        self._reloaded = anyio.Event()

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
            try:
                async with anyio.create_task_group() as tg:
                    task_status.started()
                    if self.check_every > 0:
                        tg.start_soon(self._check_against_store)
                    async for change in stream:
                        if self._next(change):  # the common case: no await, no loop pass
                            self._apply(change)
                            continue
                        async with self._lock:
                            await self._accept(change)
                    tg.cancel_scope.cancel()
            except BaseExceptionGroup as group:  # the stream's error, as itself
                if len(group.exceptions) == 1 and isinstance(group.exceptions[0], Exception):
                    raise group.exceptions[0] from None
                raise

    async def _check_against_store(self) -> None:
        """Now and then, compare with the store: a replica holding a revision the store does
        not have, or another digest at a revision both have, applied a change that did not
        come from the store (a forged publication, a replica bug): it reloads."""
        while True:
            await anyio.sleep(self.check_every)
            before = self.state.revision  # every revision held now was committed before
            try:
                info = raise_for_error(await self.transport.request(Info(), timeout=self.timeout))
            except WmError as exc:
                _log.debug("replica check: the store did not answer (%s)", exc)
                continue
            assert isinstance(info, InfoReply)
            mine = self._recent.get(info.revision)
            if info.revision < before:
                why = f"it holds revision {before}, the store is at {info.revision}"
            elif mine and info.digest and mine != info.digest:
                why = f"its revision {info.revision} is not the store's"
            else:
                continue
            async with self._lock:
                await self._diverged(why)

    async def wait_for_snapshot(self, count: int) -> None:
        """Return once the replica has loaded ``count`` snapshots in all (the first at start;
        more after a divergence or a compacted history): :meth:`statistics` tells how many."""
        while self._snapshots < count:
            await self._reloaded.wait()

    async def _diverged(self, why: str) -> None:
        self.divergences += 1
        _log.warning("the world-model replica diverged from the store (%s); reloading", why)
        await self._load_snapshot()

    def _next(self, change: Change) -> bool:
        """``change`` follows the replica's revision and no pull or reload is under way: it
        can be applied at once (applying never awaits, so nothing interleaves with it)."""
        return change.revision == self.state.revision + 1 and not self._lock.locked()

    async def _accept(self, change: Change) -> None:
        if change.revision <= self.state.revision:
            mine = self._recent.get(change.revision)
            if mine and change.digest and mine != change.digest:
                await self._diverged(f"two changes at revision {change.revision}")
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
            onto.replay, self.base_ontology, state.ontology_log
        )
        self.state = state
        self._recent = {state.revision: state.digest}
        self._follow_spatial()
        self._snapshots += 1
        self._reloaded.set()
        self._reloaded = anyio.Event()
        self._notify()

    async def _fetch_core(self) -> None:
        """The store runs another core ontology than this process's file: take the store's."""
        reply = raise_for_error(await self.transport.request(GetOntology(), timeout=self.timeout))
        assert isinstance(reply, OntologyReply)
        _log.info("the store's core ontology differs from this process's file; using the store's")
        self.base_ontology = await anyio.to_thread.run_sync(onto.Ontology.load, reply.core)

    def _follow_spatial(self) -> None:
        spatial = frozenset(n for n, r in self.ontology.relations.items() if r.spatial)
        if spatial != self._spatial or spatial != self.state.spatial_predicates:
            self._spatial = spatial
            self.state.set_spatial_predicates(spatial)

    def _apply(self, change: Change) -> None:
        for delta in change.deltas:
            self.state.apply(delta)
            if isinstance(delta, ClassDefined | TemplateDefined | TermsDefined):
                self.ontology = onto.replay(self.ontology, [delta])
                self._follow_spatial()
        self.state.revision = change.revision
        self.state.digest = change.digest
        self._recent[change.revision] = change.digest
        if len(self._recent) > _RECENT:  # applied in revision order: the first is the oldest
            del self._recent[next(iter(self._recent))]
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
