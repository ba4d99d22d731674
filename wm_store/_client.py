"""The async world-model client: local reads from a replica, writes to the store.

Usage::

    async with WmClient.connect(ZenohTransport(mesh)) as wm:
        box = await wm.add_element(Cls.KitBox, label="kit-1")
        parts = wm.resolve_element(type=Cls.Part)          # local, no round trip
        await wm.set_relation(box, Rel.contain, parts[0].id)

Reads (``get_*``, ``resolve_element``, ``query_relation``) are served from the local replica and
never block. Writes send one transaction and, by default, wait until the replica has applied it,
so a writer always reads its own writes. Every write carries a transaction id: a write that
timed out is retried once with the same id, and the store answers a retry of a committed
transaction with the first reply instead of applying it twice.

The element- and relation-centric API follows SkiROS's world-model interface (Appendix B),
typed.
"""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator, Callable, Iterable, Mapping, Sequence
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import TYPE_CHECKING

import anyio

from wm_store._errors import ConflictError, ElementNotFoundError, TransportError
from wm_store._registration import RobotRegistration, registration_ops, unregistration_ops
from wm_store._replica import Replica
from wm_store._transport import WmTransport, raise_for_error
from wm_store.protocol import (
    AddElement,
    CardinalityReply,
    Change,
    CheckCardinality,
    ClassDef,
    DefineClass,
    DefineTemplate,
    DefineTerms,
    Element,
    ElementsReply,
    Info,
    InfoReply,
    Observe,
    Op,
    PropertyFilter,
    Query,
    Relation,
    RemoveElement,
    Reply,
    Request,
    SetRelation,
    Snapshot,
    SnapshotReply,
    Sparql,
    SparqlReply,
    TemplateDef,
    TermsDef,
    Transact,
    TransactReply,
    UnsetRelation,
    UpdateElement,
    Value,
)
from wm_store.scene import match_relations, resolve

if TYPE_CHECKING:
    from wm_store.ontology import Ontology
    from wm_store.reasoners import SpatialReasoner

__all__ = ["WmClient"]

_REGISTER_ATTEMPTS = 50  # a registration re-made against a busy world model, at most


class WmClient:
    """World-model access for skills, agents and tools. Create with :meth:`connect`."""

    def __init__(
        self,
        transport: WmTransport,
        ontology: Ontology | None = None,
        *,
        author: str = "",
        timeout: float = 5.0,
        read_your_writes: bool = True,
        replica: Replica | None = None,
    ) -> None:
        """``replica``: read from this replica (kept current by whoever runs it) instead of
        a new one of this client's own (see :meth:`with_author`)."""
        self.transport = transport
        self.author = author
        self.timeout = timeout
        self.read_your_writes = read_your_writes
        self.replica = replica or Replica(transport, ontology, timeout=timeout)

    def with_author(self, author: str) -> WmClient:
        """A client writing as ``author`` that reads from this client's replica: the agents
        of one process share one replica, so a change is received, decoded and applied once
        per process, not once per agent. The new client needs no :meth:`connect` of its own;
        it works while this client's replica runs (its ``connect`` context)."""
        return WmClient(
            self.transport,
            author=author,
            timeout=self.timeout,
            read_your_writes=self.read_your_writes,
            replica=self.replica,
        )

    @classmethod
    @asynccontextmanager
    async def connect(
        cls,
        transport: WmTransport,
        ontology: Ontology | None = None,
        *,
        author: str = "",
        timeout: float = 5.0,
    ) -> AsyncIterator[WmClient]:
        """Start following the store; yields once the local replica holds a snapshot.

        The client checks against the store's ontology: the core plus everything taught to the
        store (files it started with, a scenario's terms, agents' terms, ``wm teach``), and
        follows what is taught later. It takes it compiled from the store (no rdflib in this
        process); a store of an older version makes it parse the ontology files itself.
        ``ontology``: replay the store's teaching on this core instead of the store's own
        (tests)."""
        client = cls(transport, ontology, author=author, timeout=timeout)
        try:
            async with anyio.create_task_group() as tg:
                await tg.start(client.replica.run)
                try:
                    yield client
                finally:
                    tg.cancel_scope.cancel()
        except BaseExceptionGroup as group:
            # One failure (e.g. the store is unreachable): raise it as itself, not as a group.
            if len(group.exceptions) == 1 and isinstance(group.exceptions[0], Exception):
                raise group.exceptions[0] from group
            raise

    # ------------------------------------------------------------------ local reads

    @property
    def ontology(self) -> Ontology:
        """The ontology including every class taught at run time."""
        return self.replica.ontology

    @property
    def revision(self) -> int:
        return self.replica.revision

    def get_element(self, element_id: str) -> Element:
        element = self.replica.state.get(element_id)
        if element is None:
            raise ElementNotFoundError(
                f"no element {element_id!r} (replica at rev {self.revision})"
            )
        return element

    def find_element(self, element_id: str) -> Element | None:
        return self.replica.state.get(element_id)

    def resolve_element(
        self,
        query: Query | None = None,
        *,
        type: str = "",
        label: str = "",
        filters: Sequence[PropertyFilter] = (),
        related: Sequence[Relation] = (),
        limit: int = 0,
    ) -> list[Element]:
        """Elements matching a partial description (type includes subclasses)."""
        q = query or Query(type=type, label=label, filters=list(filters), related=list(related))
        return resolve(self.replica.state, self.ontology, q, limit)

    def query_relation(
        self, subject: str = "", predicate: str = "", obj: str = ""
    ) -> list[Relation]:
        """Relations matching a pattern; empty or ``"*"`` matches anything."""
        return match_relations(self.replica.state, self.ontology, subject, predicate, obj)

    def get_parent(self, element_id: str) -> Element | None:
        """The element's spatial parent (the one that contains / has it)."""
        self.get_element(element_id)
        rel = self.replica.state.parent(element_id)
        return None if rel is None else self.get_element(rel.subject)

    def get_children(self, element_id: str, predicate: str = "", type: str = "") -> list[Element]:
        """Objects of ``predicate`` relations from the element (spatial ones by default)."""
        self.get_element(element_id)
        if predicate:
            rels = self.query_relation(element_id, predicate)
        else:
            rels = self.replica.state.spatial_children(element_id)
        children = [self.get_element(r.object) for r in rels]
        if type:
            types = self.ontology.subclasses(self.ontology.check_class(type))
            children = [c for c in children if c.type in types]
        return children

    def get_default_element(self, name: str) -> Element:
        """An unsaved element filled from a default individual (by template or class name)."""
        template = self.ontology.template(name)
        return Element(
            id="", type=template.type, label=template.label, properties=dict(template.properties)
        )

    def classify(
        self, element: Element, candidates_type: str, threshold: float = 0.5
    ) -> list[tuple[str, float]]:
        """Default individuals (templates) of ``candidates_type`` that ``element`` resembles,
        with similarity scores >= ``threshold``, best first (SkiROS ``classify``)."""
        from wm_store.reasoners import classify  # the reasoners load when first used

        return classify(self.replica.state, self.ontology, element, candidates_type, threshold)

    def identify(self, observed: Element, threshold: float = 0.5) -> list[tuple[str, float]]:
        """Existing elements that ``observed`` may be, best first (SkiROS ``identify``)."""
        from wm_store.reasoners import identify

        return identify(self.replica.state, self.ontology, observed, threshold)

    @property
    def spatial(self) -> SpatialReasoner:
        """Poses in the world frame, relative poses, inside/on tests over the replica."""
        from wm_store.reasoners import SpatialReasoner

        return SpatialReasoner(self.replica.state, self.ontology)

    # ------------------------------------------------------------------ remote reads

    async def request(self, request: Request) -> Reply:
        """Send any request; error replies raise the matching exception."""
        return raise_for_error(await self.transport.request(request, timeout=self.timeout))

    async def sparql(self, query: str, bindings: Mapping[str, str] | None = None) -> SparqlReply:
        reply = await self.request(Sparql(query=query, bindings=dict(bindings or {})))
        assert isinstance(reply, SparqlReply)
        return reply

    async def snapshot(self, revision: int | None = None) -> SnapshotReply:
        reply = await self.request(Snapshot(revision=revision))
        assert isinstance(reply, SnapshotReply)
        return reply

    async def info(self) -> InfoReply:
        reply = await self.request(Info())
        assert isinstance(reply, InfoReply)
        return reply

    async def check_cardinality(self, ids: Sequence[str] = ()) -> CardinalityReply:
        """The store's report of minimum cardinalities not met, for ``ids`` (default: every
        element). Maximums never need this: the store refuses a write that would exceed one."""
        reply = await self.request(CheckCardinality(ids=list(ids)))
        assert isinstance(reply, CardinalityReply)
        return reply

    async def fetch_elements(self, query: Query) -> list[Element]:
        """Resolve on the store instead of the replica (for tools with no replica)."""
        from wm_store.protocol import Resolve

        reply = await self.request(Resolve(query=query))
        assert isinstance(reply, ElementsReply)
        return reply.elements

    # ------------------------------------------------------------------ writes

    async def transact(
        self, ops: Sequence[Op], *, expect_revision: int | None = None, txn_id: str = ""
    ) -> TransactReply:
        """Commit ``ops`` atomically; waits until the replica shows the result."""
        request = Transact(
            ops=list(ops),
            txn_id=txn_id or uuid.uuid4().hex,
            author=self.author,
            expect_revision=expect_revision,
        )
        try:
            reply = await self.request(request)
        except TransportError:
            reply = await self.request(request)  # same txn_id: applied at most once
        assert isinstance(reply, TransactReply)
        if self.read_your_writes:
            await self.replica.wait_for_revision(reply.revision)
        return reply

    async def add_element(
        self,
        type: str,
        label: str = "",
        properties: Mapping[str, Value] | None = None,
        relations: Iterable[Relation] = (),
    ) -> str:
        """Add one element; returns its new id. In ``relations``, ``"$"`` is the new element."""
        op = AddElement(
            type=type,
            label=label,
            properties=dict(properties or {}),
            relations=list(relations),
            ref="$new",
        )
        return (await self.transact([op])).ids["$new"]

    async def add_branch(
        self,
        parent: str,
        predicate: str,
        type: str,
        label: str = "",
        properties: Mapping[str, Value] | None = None,
    ) -> str:
        """Add an element under ``parent`` (``predicate(parent, new)``); returns its id."""
        return await self.add_element(type, label, properties, [Relation(parent, predicate, "$")])

    async def update_element(
        self,
        element_id: str,
        properties: Mapping[str, Value] | None = None,
        *,
        remove: Sequence[str] = (),
        label: str | None = None,
        replace: bool = False,
        expect_rev: int | None = None,
    ) -> int:
        """Merge (or replace) properties; ``None`` values delete. Returns the new revision."""
        op = UpdateElement(
            id=element_id,
            properties=dict(properties or {}),
            remove=list(remove),
            label=label,
            mode="replace" if replace else "merge",
            expect_rev=expect_rev,
        )
        return (await self.transact([op])).revision

    async def observe(
        self, element_id: str, prop: str, value: Value, *, source: str, confidence: float = 1.0
    ) -> int:
        """Report ``source``'s observation of a property (resolved by the property's policy)."""
        op = Observe(
            id=element_id, property=prop, value=value, source=source, confidence=confidence
        )
        return (await self.transact([op])).revision

    async def remove_element(self, element_id: str, *, expect_rev: int | None = None) -> int:
        return (await self.transact([RemoveElement(id=element_id, expect_rev=expect_rev)])).revision

    async def remove_branch(self, element_id: str) -> int:
        """Remove the element and everything it spatially contains."""
        return (await self.transact([RemoveElement(id=element_id, branch=True)])).revision

    async def set_relation(self, subject: str, predicate: str, obj: str) -> int:
        return (
            await self.transact([SetRelation(subject=subject, predicate=predicate, object=obj)])
        ).revision

    async def unset_relation(self, subject: str, predicate: str, obj: str) -> int:
        op = UnsetRelation(subject=subject, predicate=predicate, object=obj)
        return (await self.transact([op])).revision

    async def define_class(
        self, name: str, parent: str, *, label: str = "", comment: str = ""
    ) -> int:
        """Teach the ontology a new class while the system runs (persisted and published)."""
        op = DefineClass(cls=ClassDef(name=name, parent=parent, label=label, comment=comment))
        return (await self.transact([op])).revision

    async def define_template(self, template: TemplateDef) -> int:
        return (await self.transact([DefineTemplate(template=template)])).revision

    async def teach(self, turtle: str, *, source: str = "") -> int:
        """Teach the store's ontology the Turtle ``turtle`` (classes, relations, data
        properties, restrictions, templates): persisted, published to every process, exported
        by ``wm export``. Terms it already has change nothing. Returns the revision after it;
        this client's :attr:`ontology` has the terms when it returns.

        Raises:
            OntologyError: the text is not Turtle, or the terms do not fit the ontology.
        """
        op = DefineTerms(terms=TermsDef(turtle=turtle, source=source or self.author))
        return (await self.transact([op])).revision

    async def define_relation(
        self,
        name: str,
        *,
        domain: Sequence[str] = (),
        range: Sequence[str] = (),
        parent: str = "",
        label: str = "",
        comment: str = "",
    ) -> int:
        """Teach a new relation between classes (SkiROS learns concepts during operation)."""
        from wm_store.ontology import relation_turtle  # rdflib, only when teaching

        text = relation_turtle(
            name, domain=domain, range=range, parent=parent, label=label, comment=comment
        )
        return await self.teach(text, source=f"relation {name}")

    async def define_property(
        self,
        name: str,
        *,
        kind: str,
        domain: Sequence[str] = (),
        minimum: float | None = None,
        maximum: float | None = None,
        label: str = "",
        comment: str = "",
    ) -> int:
        """Teach a new data property of value ``kind`` (float, int, bool, string, Pose...)."""
        from wm_store.ontology import property_turtle  # rdflib, only when teaching

        text = property_turtle(
            name,
            kind=kind,
            domain=domain,
            minimum=minimum,
            maximum=maximum,
            label=label,
            comment=comment,
        )
        return await self.teach(text, source=f"property {name}")

    # ------------------------------------------------------------------ registration

    async def register_robot(self, registration: RobotRegistration) -> dict[str, str]:
        """Register an agent, its robot, devices and skills (SkiROS ``registerRobot``).

        Returns the ids by ref: ``$agent``, ``$robot``, ``$device:<label>``, ``$skill:<name>``
        for the elements this call created (existing ones are reused). The transaction is
        made from this replica and committed only if the store is still at the replica's
        revision; otherwise it is made again once the replica caught up (two agents of one
        robot starting together must find, not both add, the robot)."""
        onto = self.ontology
        subclasses = {name: onto.subclasses(name) for name in ("Agent", "Robot", "Skill")}
        for _attempt in range(_REGISTER_ATTEMPTS):
            state = self.replica.state
            made_at = state.revision  # the state changes in place as the replica catches up
            ops = registration_ops(state, registration, subclasses=subclasses)
            try:
                reply = await self.transact(ops, expect_revision=made_at)
            except ConflictError:  # the store moved on: catch up with it, then look again
                await self.replica.wait_for_revision(made_at + 1)
                continue
            return {k: v for k, v in reply.ids.items() if k.startswith("$")}
        raise ConflictError(
            f"registering agent {registration.agent!r}: the world model changed under each of "
            f"{_REGISTER_ATTEMPTS} attempts"
        )

    async def unregister_robot(self, agent: str) -> None:
        """Remove the agent and its skills from the world model (the robot stays)."""
        ops = unregistration_ops(
            self.replica.state, agent, agent_types=self.ontology.subclasses("Agent")
        )
        if ops:
            await self.transact(ops)

    # ------------------------------------------------------------------ watching

    async def wait_for_revision(self, revision: int, *, timeout: float | None = None) -> None:
        await self.replica.wait_for_revision(revision, timeout=timeout)

    def on_change(self, callback: Callable[[Change], None]) -> Callable[[], None]:
        return self.replica.on_change(callback)

    def watch(self) -> AbstractAsyncContextManager[AsyncIterator[Change]]:
        """``async with wm.watch() as changes: async for change in changes: ...``"""
        return self.replica.watch()
