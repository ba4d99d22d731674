"""Requests to the store: queries, reads, transactions and history (:data:`Request`)."""

from __future__ import annotations

from typing import Annotated, Literal, TypeAlias

from msgspec import Meta, Struct

from wm_store.protocol._ops import Op
from wm_store.protocol._values import NonNeg, Relation, Value

# --------------------------------------------------------------------------- requests

Comparator: TypeAlias = Literal["eq", "ne", "lt", "le", "gt", "ge", "exists", "near"]


class PropertyFilter(Struct, frozen=True, kw_only=True):
    """``property <op> value``; ``near`` compares positions/numbers within ``tolerance``."""

    property: str
    op: Comparator = "eq"
    value: Value = None
    tolerance: NonNeg = 0.0


class Query(Struct, frozen=True, kw_only=True):
    """A partial element: matches elements of ``type`` (and its subclasses unless
    ``exact_type``), with ``label`` if given, satisfying every filter."""

    type: str = ""
    exact_type: bool = False
    label: str = ""
    filters: list[PropertyFilter] = []
    related: list[Relation] = []
    """Relations the element must take part in; use ``"?"`` for the element itself and
    ``"*"`` as a wildcard, e.g. ``Relation("KitBox-1", "contain", "?")``."""


class GetElements(Struct, tag=True, tag_field="request", kw_only=True):
    ids: list[str]


class Resolve(Struct, tag=True, tag_field="request", kw_only=True):
    query: Query
    limit: Annotated[int, Meta(ge=0)] = 0


class Relations(Struct, tag=True, tag_field="request", kw_only=True):
    """Relations matching the pattern; an empty field is a wildcard."""

    subject: str = ""
    predicate: str = ""
    object: str = ""
    include_subproperties: bool = True


class Parent(Struct, tag=True, tag_field="request", kw_only=True):
    id: str


class Sparql(Struct, tag=True, tag_field="request", kw_only=True):
    """A read-only SPARQL query over ontology + scene. ``bindings`` are initial bindings of
    variables (values are substituted as literals or element IRIs, never spliced as text)."""

    query: str
    bindings: dict[str, str] = {}


class Transact(Struct, tag=True, tag_field="request", kw_only=True):
    """Apply ``ops`` atomically. ``expect_revision``: commit only if the store is still at that
    revision. ``txn_id``: an idempotency key; re-sending a committed id returns the first reply."""

    ops: list[Op]
    txn_id: str = ""
    author: str = ""
    expect_revision: int | None = None


class Snapshot(Struct, tag=True, tag_field="request", kw_only=True):
    """The whole scene (and ontology extensions) at ``revision`` (default: now)."""

    revision: int | None = None


class ChangesSince(Struct, tag=True, tag_field="request", kw_only=True):
    """Every change with a revision greater than ``revision``, in order."""

    revision: Annotated[int, Meta(ge=0)]
    limit: Annotated[int, Meta(ge=0)] = 0


class Info(Struct, tag=True, tag_field="request", kw_only=True):
    pass


class GetOntology(Struct, tag=True, tag_field="request", kw_only=True):
    """The store's ontology (:class:`~wm_store.protocol.OntologyReply`): the one every
    process of the mesh checks against."""


class GetCompiledOntology(Struct, tag=True, tag_field="request", kw_only=True):
    """The store's ontology compiled (:class:`~wm_store.protocol.CompiledOntologyReply`): what
    it checks against, core and everything taught, in a form that decodes without rdflib."""


class CheckCardinality(Struct, tag=True, tag_field="request", kw_only=True):
    """Which elements fall short of a minimum cardinality of their class (read-only).

    Maximums are enforced on every write; minimums cannot be (a robot is added before its
    arm), so the store reports them on request. ``ids``: check only these elements (default:
    every element)."""

    ids: list[str] = []


Request: TypeAlias = (
    GetElements
    | Resolve
    | Relations
    | Parent
    | Sparql
    | Transact
    | Snapshot
    | ChangesSince
    | Info
    | CheckCardinality
    | GetOntology
    | GetCompiledOntology
)
