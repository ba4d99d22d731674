"""The authoritative world-model store (transport-free core of ``skimesh wm``).

:class:`WmStore` owns the scene state, the ontology (with its run-time extensions), the durable
log and a bounded history of changes. A transaction is validated and applied in memory at once
(so revisions are assigned in a total order), then made durable; its caller is answered, and
the :class:`~wm_store.protocol.Change` is handed to listeners, only after it is durable, and
always in revision order.

Reads see every applied transaction, including one whose fsync is still under way (a window of
about a millisecond). If the durable log fails, the store stops accepting writes: a store must
never acknowledge what it could not persist.

Run :meth:`WmStore.run` in a task group before writing; it drives the log writer and the
periodic snapshots. Without a data directory the store is memory-only (tests, the demo).
"""

from __future__ import annotations

import hashlib
import time
from collections import OrderedDict, deque
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Literal

import anyio
import msgspec
from anyio.abc import TaskStatus
from msgspec import Meta

from meshlink.rpc import encode
from wm_store._errors import ConflictError, HistoryCompactedError, StorageError, ValidationError
from wm_store.durability import Durability
from wm_store.ontology import Ontology, parse_terms, replay
from wm_store.protocol import (
    AddElement,
    Change,
    ChangesReply,
    DefineTerms,
    Delta,
    InfoReply,
    OntologyReply,
    Op,
    SnapshotReply,
    TermsDef,
    Transact,
    TransactReply,
)
from wm_store.scene import (
    Ownership,
    SceneState,
    Undo,
    apply_transaction,
    changes_ownership,
    check_writer,
    ownership,
)

__all__ = ["ChangeListener", "StoreConfig", "WmStore"]

ChangeListener = Callable[[Change, bytes], None]
"""Called with each durable change and its encoded bytes, in revision order, on the loop."""


class StoreConfig(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    data_dir: str | None = None
    """Where the log and snapshots live; ``None`` keeps everything in memory."""
    durability: Literal["fsync", "group", "none"] = "group"
    snapshot_every: Annotated[int, Meta(ge=1)] = 10_000
    """Write a snapshot (and compact the log) after this many revisions."""
    history: Annotated[int, Meta(ge=1)] = 10_000
    """How many recent changes are kept for ``changes-since`` and past snapshots."""
    sparql_timeout: Annotated[float, Meta(gt=0)] = 10.0
    """Seconds a SPARQL query (with the graph build it needs) may run before it is ended."""
    sparql_max_text: Annotated[int, Meta(ge=1)] = 16 * 1024
    """Longest SPARQL text accepted, bytes."""
    sparql_max_rows: Annotated[int, Meta(ge=1)] = 10_000
    """Most rows (or triples) a SPARQL reply may hold."""
    max_ops: Annotated[int, Meta(ge=1)] = 10_000
    """Largest number of ops one transaction may carry."""
    dedupe: Annotated[int, Meta(ge=0)] = 10_000
    """How many recent transaction ids are remembered for idempotent retries."""
    controllers: dict[str, list[str]] = {}
    """Robot (or appliance) label -> the agents that may control it. An agent may join a robot
    another agent controls (a split robot) only if it is named here for that robot; a robot
    not named here may be joined by any agent (see ``wm_store.scene.check_writer``)."""


def chain_digest(previous: str, deltas: bytes) -> str:
    """The digest after a change: BLAKE2b-128 of the previous digest and the change's encoded
    deltas (hex)."""
    return hashlib.blake2b(previous.encode() + deltas, digest_size=16).hexdigest()


class _DiskSnapshot(msgspec.Struct):
    """What a snapshot file holds: the scene and the recent transaction ids (for dedupe)."""

    scene: SnapshotReply
    txns: list[tuple[str, TransactReply]] = []


class _Entry(msgspec.Struct):
    change: Change
    payload: bytes
    undo: list[Undo]


class WmStore:
    """Scene state + ontology + durable log + history. One instance per store process."""

    def __init__(self, ontology: Ontology, config: StoreConfig | None = None) -> None:
        self.config = config or StoreConfig()
        self.ontology = ontology
        self.state = SceneState()
        self.state.set_spatial_predicates(n for n, r in ontology.relations.items() if r.spatial)
        self.started_at = time.time()
        self.recovery_detail = ""
        self._base_ontology = ontology
        self._core_text: str | None = None
        self._durability: Durability | None = None
        self._history: deque[_Entry] = deque(maxlen=self.config.history)
        self._txn_revisions: OrderedDict[str, TransactReply] = OrderedDict()
        self._listeners: list[ChangeListener] = []
        self._durable_done: dict[int, _Entry] = {}
        self._published = 0
        self._last_snapshot = 0
        self._failed: StorageError | None = None
        self._snapshot_wanted = anyio.Event()
        self._published_changed = anyio.Event()
        self._owners: Ownership | None = None
        """Who owns what (``wm_store.scene.ownership``), kept until a change touches it."""

    # ------------------------------------------------------------------ life cycle

    @classmethod
    async def open(cls, ontology: Ontology, config: StoreConfig | None = None) -> WmStore:
        """Create the store and recover it from its data directory (if any)."""
        store = cls(ontology, config)
        if store.config.data_dir is not None:
            await store._recover(Path(store.config.data_dir))
        return store

    async def _recover(self, data_dir: Path) -> None:
        durability, recovered = await Durability.open(data_dir, mode=self.config.durability)
        self._durability = durability
        if recovered.snapshot is not None:
            seq, payload = recovered.snapshot
            disk = msgspec.msgpack.decode(payload, type=_DiskSnapshot)
            self.state = SceneState.from_snapshot(disk.scene, self.state.spatial_predicates)
            self._txn_revisions.update(disk.txns)
            self._reload_ontology()
            self._last_snapshot = seq
        for seq, payload in recovered.records:
            change = msgspec.msgpack.decode(payload, type=Change)
            if change.revision != seq or seq != self.state.revision + 1:
                raise StorageError(
                    f"log record {seq} does not follow revision {self.state.revision}"
                )
            undo = [self.state.apply(d) for d in change.deltas]
            self.state.revision = seq
            self.state.digest = change.digest or chain_digest(
                self.state.digest, encode(change.deltas)
            )
            self._remember(_Entry(change, payload, undo))
        self._reload_ontology()
        self._published = self.state.revision
        details = [recovered.report.detail, recovered.snapshot_error or ""]
        self.recovery_detail = "; ".join(d for d in details if d)

    def _reload_ontology(self) -> None:
        self.ontology = replay(self._base_ontology, self.state.ontology_log)
        self.state.set_spatial_predicates(
            n for n, r in self.ontology.relations.items() if r.spatial
        )

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Drive the durable log and periodic snapshots until cancelled."""
        async with anyio.create_task_group() as tg:
            if self._durability is not None:
                await tg.start(self._durability.run)
                tg.start_soon(self._snapshotter)
            task_status.started()
            await anyio.sleep_forever()

    async def aclose(self) -> None:
        """Write a final snapshot and close the log (call after :meth:`run` was cancelled)."""
        if self._durability is not None:
            with anyio.CancelScope(shield=True):
                # Only a fully durable state may be snapshotted: transactions applied in memory
                # whose commit did not finish must not reach the disk by the back door.
                durable = self._failed is None and self._published == self.state.revision
                if durable and self.state.revision > self._last_snapshot:
                    await self._write_snapshot()
                await self._durability.aclose()

    # ------------------------------------------------------------------ writes

    def add_listener(self, listener: ChangeListener) -> None:
        self._listeners.append(listener)

    def remove_listener(self, listener: ChangeListener) -> None:
        self._listeners.remove(listener)

    async def transact(self, request: Transact) -> TransactReply:
        """Validate, apply, persist and publish one transaction; return its revision and ids.

        Raises a :class:`~wm_store.ValidationError` subclass (state unchanged) or
        :class:`~wm_store.StorageError` (the store can no longer write).
        """
        if self._failed is not None:
            raise StorageError(f"the store stopped accepting writes: {self._failed}")
        if not request.ops:
            raise ValidationError("an empty transaction: give at least one op")
        if len(request.ops) > self.config.max_ops:
            raise ConflictError(f"{len(request.ops)} ops exceed the limit of {self.config.max_ops}")
        if request.txn_id and request.txn_id in self._txn_revisions:
            first = self._txn_revisions[request.txn_id]
            await self._wait_published(first.revision)
            return msgspec.structs.replace(first, duplicate=True)
        parsed = {
            i: await anyio.to_thread.run_sync(parse_terms, op.terms.turtle, op.terms.source)
            for i, op in enumerate(request.ops)
            if isinstance(op, DefineTerms)
        }  # Turtle is parsed off the event loop; the state is read only after this point
        if request.expect_revision is not None and request.expect_revision != self.state.revision:
            raise ConflictError(
                f"the store is at revision {self.state.revision}, "
                f"not the expected {request.expect_revision}"
            )
        revision = self.state.revision + 1
        now = time.time()
        result = apply_transaction(
            self.state,
            self.ontology,
            request.ops,
            revision=revision,
            now=now,
            parsed_terms=parsed,
            check=self._authorization(request),
        )
        if not result.deltas:  # nothing changed (e.g. terms the ontology already has)
            return TransactReply(revision=self.state.revision, ids=result.ids)
        if self._owners is not None:
            kinds = self.ontology.subclasses("Agent") | self.ontology.subclasses("Device")
            if changes_ownership(self._owners, result.deltas, kinds):
                self._owners = None
        self.state.revision = revision
        self.state.digest = chain_digest(self.state.digest, encode(result.deltas))
        self.ontology = result.ontology
        refs = {k: v for k, v in result.ids.items() if not k.startswith("#")}
        change = Change(
            revision=revision,
            deltas=result.deltas,
            stamp=now,
            txn_id=request.txn_id,
            author=request.author,
            ids=refs,
            digest=self.state.digest,
        )
        entry = _Entry(change, encode(change), result.undo)
        reply = TransactReply(revision=revision, ids=result.ids)
        self._remember(entry, reply)
        if self._durability is not None:
            try:
                await self._durability.commit(revision, entry.payload)
            except StorageError as exc:
                self._failed = exc
                self._published_changed.set()
                raise
        self._durable_done[revision] = entry
        self._publish_ready()
        await self._wait_published(revision)
        return reply

    def _authorization(self, request: Transact) -> Callable[[list[Delta]], None] | None:
        """The check that refuses an agent's write to what another agent registered, made
        from the state before the transaction; None when the author cannot be an agent (no
        element has its label and the transaction adds none with it)."""
        author, state = request.author, self.state
        if not author or not (
            state.ids_with_label(author)
            or any(isinstance(op, AddElement) and op.label == author for op in request.ops)
        ):
            return None
        onto = self.ontology
        agent_types = onto.subclasses("Agent")
        if self._owners is None:  # made again only after a change to the registrations
            self._owners = ownership(state, agent_types, onto.subclasses("Device"))
        before = self._owners
        controllers = self.config.controllers

        def check(deltas: list[Delta]) -> None:
            check_writer(before, deltas, author, agent_types=agent_types, controllers=controllers)

        return check

    def _remember(self, entry: _Entry, reply: TransactReply | None = None) -> None:
        self._history.append(entry)
        txn_id = entry.change.txn_id
        if txn_id and self.config.dedupe:
            self._txn_revisions[txn_id] = reply or TransactReply(
                revision=entry.change.revision, ids=entry.change.ids
            )
            while len(self._txn_revisions) > self.config.dedupe:
                self._txn_revisions.popitem(last=False)

    def _publish_ready(self) -> None:
        advanced = False
        while (entry := self._durable_done.pop(self._published + 1, None)) is not None:
            self._published += 1
            advanced = True
            for listener in list(self._listeners):
                listener(entry.change, entry.payload)
        if advanced:
            self._published_changed.set()
            self._published_changed = anyio.Event()
        if self._published - self._last_snapshot >= self.config.snapshot_every:
            self._snapshot_wanted.set()

    async def _wait_published(self, revision: int) -> None:
        while self._published < revision:
            if self._failed is not None:
                raise StorageError(f"the store stopped accepting writes: {self._failed}")
            await self._published_changed.wait()

    # ------------------------------------------------------------------ snapshots

    async def _snapshotter(self) -> None:
        while True:
            await self._snapshot_wanted.wait()
            self._snapshot_wanted = anyio.Event()
            await self._write_snapshot()

    async def _write_snapshot(self) -> None:
        assert self._durability is not None
        snap = _DiskSnapshot(self.snapshot(), list(self._txn_revisions.items()))
        payload = await anyio.to_thread.run_sync(encode, snap)
        await self._durability.write_snapshot(snap.scene.revision, payload)
        self._last_snapshot = snap.scene.revision

    # ------------------------------------------------------------------ reads

    @property
    def revision(self) -> int:
        return self.state.revision

    async def teach(self, turtle: str, source: str, *, author: str = "") -> int:
        """Teach the ontology the Turtle ``turtle`` (a no-op if it adds nothing); returns the
        revision after it. Raises OntologyError naming ``source``."""
        ops: list[Op] = [DefineTerms(terms=TermsDef(turtle=turtle, source=source))]
        reply = await self.transact(Transact(ops=ops, author=author or "wm"))
        return reply.revision

    def core_ontology(self) -> tuple[str, str]:
        """The core ontology the log is replayed on, as (digest, Turtle text)."""
        if self._core_text is None:
            self._core_text = self._base_ontology.core_turtle()
        return self._base_ontology.digest, self._core_text

    def ontology_reply(self) -> OntologyReply:
        """The store's ontology: its core text and what was taught since, in order."""
        digest, core = self.core_ontology()
        return OntologyReply(
            revision=self.state.revision,
            core=core,
            core_digest=digest,
            taught=list(self.state.ontology_log),
        )

    @property
    def core_digest(self) -> str:
        """The digest of the core ontology the store's log is replayed on."""
        return self._base_ontology.digest

    def snapshot(self, revision: int | None = None) -> SnapshotReply:
        """The scene now, or at an earlier ``revision`` still within the kept history."""
        if revision is None or revision == self.state.revision:
            return self.state.to_snapshot()
        if revision > self.state.revision or revision < self.oldest_revision():
            raise HistoryCompactedError(
                f"revision {revision} is not available: the store keeps "
                f"{self.oldest_revision()}..{self.state.revision}"
            )
        past = self.state.copy()
        for entry in reversed(self._history):
            if entry.change.revision <= revision:
                break
            for record in reversed(entry.undo):
                past.undo(record)
        past.revision = revision
        past.digest = next(
            (e.change.digest for e in self._history if e.change.revision == revision), ""
        )
        return past.to_snapshot()

    def oldest_revision(self) -> int:
        """The oldest revision a snapshot or ``changes_since`` can start from."""
        if not self._history:
            return self.state.revision
        return self._history[0].change.revision - 1

    def changes_since(self, revision: int, limit: int = 0) -> ChangesReply:
        changes = [e.change for e in self._published_since(revision)]
        if limit:
            changes = changes[:limit]
        return ChangesReply(revision=self._published, changes=changes)

    def encoded_changes_since(self, revision: int) -> tuple[list[bytes], int]:
        """Like :meth:`changes_since`: each change as the bytes it was published as (nothing
        is encoded again), and the revision they lead to."""
        entries = self._published_since(revision)
        return [e.payload for e in entries], entries[-1].change.revision if entries else revision

    def _published_since(self, revision: int) -> list[_Entry]:
        if revision > self.state.revision:
            raise ConflictError(
                f"revision {revision} is ahead of the store ({self.state.revision})"
            )
        if revision < self.oldest_revision():
            raise HistoryCompactedError(
                f"changes after {revision} are no longer kept (oldest: {self.oldest_revision()}); "
                "take a snapshot instead"
            )
        return [e for e in self._history if revision < e.change.revision <= self._published]

    def info(self) -> InfoReply:
        return InfoReply(
            revision=self.state.revision,
            elements=len(self.state.elements),
            relations=self.state.relation_count,
            oldest_change=self.oldest_revision(),
            durability=self.config.durability if self.config.data_dir else "memory",
            data_dir=self.config.data_dir or "",
            started_at=self.started_at,
            digest=self.state.digest,
        )
