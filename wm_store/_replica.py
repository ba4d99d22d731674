"""The client's local replica of the world model.

The replica subscribes to the change stream *first*, then loads a snapshot, then applies every
change whose revision follows its own. A change that skips revisions is a gap (a message lost,
a subscriber that joined late, a store restart): the replica asks for ``changes-since`` its
revision and, if the store no longer keeps them, reloads a snapshot. Changes it already has are
ignored, so nothing is applied twice and nothing is lost.

The replica checks against the store's ontology, taken compiled from the store
(:class:`~wm_store.protocol.GetCompiledOntology`, before each snapshot): no rdflib in the
process. Classes and templates defined later extend it here; taught Turtle terms make it fetch
the store's again before the change that carries them is applied (a compiled ontology parses
no Turtle). A store that serves none (an older version) makes it parse the ontology files and
replay the store's log itself, as it does when given a core.

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

from wm_store import ontology as onto  # a lazy face; a compiled ontology needs no rdflib
from wm_store._errors import (
    HistoryCompactedError,
    OntologyError,
    ProtocolError,
    RevisionTimeoutError,
    WmError,
)
from wm_store._transport import WmTransport, raise_for_error
from wm_store.protocol import (
    Change,
    ChangesReply,
    ChangesSince,
    ClassDefined,
    CompiledOntologyReply,
    GetCompiledOntology,
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

_ONTOLOGY_DELTAS = (ClassDefined, TemplateDefined, TermsDefined)

_log = logging.getLogger(__name__)

_RECENT = 1024
"""How many digests of applied changes a replica keeps to compare with the store's."""


def _spatial_of(ontology: Ontology) -> frozenset[str]:
    return frozenset(n for n, r in ontology.relations.items() if r.spatial)


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
        self._base = base_ontology
        """The core the store's ontology log is replayed on when this process parses the OWL
        files itself (rdflib): the one given, or this process's core file (the store's own
        when the digests agree, else fetched). None while the store's compiled ontology is
        followed."""
        self._from_store = base_ontology is None
        """Follow the store's compiled ontology (:class:`GetCompiledOntology`: no rdflib);
        False when a core was given, or the store serves no compiled ontology (an older
        version)."""
        self._ontology = base_ontology
        self._covered = 0
        """How many deltas of the store's ontology log :attr:`ontology` holds (a compiled
        ontology may hold more than the replica has applied: those are skipped)."""
        self.timeout = timeout
        self.catch_up_after = catch_up_after
        self.state = SceneState()
        self._spatial = _spatial_of(base_ontology) if base_ontology else frozenset()
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
    def ontology(self) -> Ontology:
        """The store's ontology as of this replica's revision: core and what was taught (the
        core file's, parsed here, if read before the first snapshot)."""
        if self._ontology is None:
            self._ontology = onto.Ontology.default()
        return self._ontology

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
        return (
            change.revision == self.state.revision + 1
            and not self._lock.locked()
            and not self._teaches_beyond(change)
        )

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
        await self._apply_fetching(change)

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
                await self._apply_fetching(change)

    async def _load_snapshot(self) -> None:
        if self._from_store:
            await self._fetch_compiled()  # before the snapshot: it holds at most its log
        reply = raise_for_error(await self.transport.request(Snapshot(), timeout=self.timeout))
        assert isinstance(reply, SnapshotReply)
        log = reply.ontology
        if (
            self._from_store
            and (
                self._covered > len(log)  # a store restarted in between, with a shorter log
                or any(isinstance(d, TermsDefined) for d in log[self._covered :])  # terms taught
            )
        ):
            await self._fetch_compiled()  # now it holds at least the snapshot's log
        if not self._from_store:
            await self._use_files(reply.core_digest)
        if tail := log[self._covered :]:
            self._ontology = await anyio.to_thread.run_sync(onto.replay, self.ontology, tail)
        self._covered = max(self._covered, len(log))
        self._spatial = _spatial_of(self.ontology)
        state = SceneState.from_snapshot(reply, self._spatial)
        self.state = state
        self._recent = {state.revision: state.digest}
        self._follow_spatial()
        self._snapshots += 1
        self._reloaded.set()
        self._reloaded = anyio.Event()
        self._notify()

    async def _fetch_compiled(self) -> bool:
        """Take the store's ontology, compiled (no rdflib here); False when the store serves
        none this version reads (an older store): this replica parses the ontology files
        itself from then on."""
        request = GetCompiledOntology()
        try:
            reply = raise_for_error(await self.transport.request(request, timeout=self.timeout))
            assert isinstance(reply, CompiledOntologyReply)
            ontology = onto.Ontology.from_compiled(reply.compiled)
        except (ProtocolError, OntologyError) as exc:
            _log.warning(
                "the world-model store serves no compiled ontology this version reads (%s): "
                "this process parses the ontology files itself (rdflib)",
                exc,
            )
            self._from_store = False
            return False
        self._ontology, self._covered = ontology, reply.taught
        return True

    async def _use_files(self, core_digest: str) -> None:
        """Start from a core parsed here (rdflib): this process's core file, or the store's
        core text when ``core_digest`` says the store runs another one."""
        if self._base is None:
            self._base = await anyio.to_thread.run_sync(onto.Ontology.default)
        if not self._own_base and core_digest not in ("", self._base.digest):
            await self._fetch_core()
        self._ontology, self._covered = self._base, 0

    def _teaches_beyond(self, change: Change) -> bool:
        """``change`` teaches terms the store's compiled ontology, as this replica holds it,
        lacks: a compiled ontology parses no Turtle, so the store's is fetched first."""
        if not self._from_store:
            return False
        for delta in change.deltas:  # a plain loop: this runs for every change of the stream
            if isinstance(delta, TermsDefined):
                break
        else:
            return False
        ontological = [d for d in change.deltas if isinstance(d, _ONTOLOGY_DELTAS)]
        new = ontological[max(0, self._covered - len(self.state.ontology_log)) :]
        return any(isinstance(d, TermsDefined) for d in new)

    async def _apply_fetching(self, change: Change) -> None:
        """:meth:`_apply`, after fetching the store's ontology when ``change`` teaches terms."""
        if self._teaches_beyond(change) and not await self._fetch_compiled():
            await self._load_snapshot()  # parsed here from now on; the snapshot holds it
            return
        self._apply(change)

    async def _fetch_core(self) -> None:
        """The store runs another core ontology than this process's file: take the store's."""
        reply = raise_for_error(await self.transport.request(GetOntology(), timeout=self.timeout))
        assert isinstance(reply, OntologyReply)
        _log.info("the store's core ontology differs from this process's file; using the store's")
        self._base = await anyio.to_thread.run_sync(onto.Ontology.load, reply.core)

    def _follow_spatial(self) -> None:
        spatial = _spatial_of(self.ontology)
        if spatial != self._spatial or spatial != self.state.spatial_predicates:
            self._spatial = spatial
            self.state.set_spatial_predicates(spatial)

    def _apply(self, change: Change) -> None:
        for delta in change.deltas:
            self.state.apply(delta)
            if isinstance(delta, _ONTOLOGY_DELTAS):
                log = self.state.ontology_log
                if len(log) > self._covered:  # else the compiled ontology holds it already
                    self._ontology = onto.replay(self.ontology, log[self._covered :])
                    self._covered = len(log)
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
