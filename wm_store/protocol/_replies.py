"""Replies of the store, one per request kind, and :class:`meshlink.rpc.ErrorReply` (the
refusal every skimesh service answers with): :data:`Reply`."""

from __future__ import annotations

from typing import TypeAlias

from msgspec import Struct

from meshlink.rpc import ErrorReply
from wm_store.protocol._changes import Change, OntologyDelta
from wm_store.protocol._values import SCHEMA_VERSION, ClassDef, Element, Relation, TemplateDef

# --------------------------------------------------------------------------- replies


class ElementsReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    elements: list[Element]
    schema_version: int = SCHEMA_VERSION


class RelationsReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    relations: list[Relation]
    schema_version: int = SCHEMA_VERSION


class SparqlReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    variables: list[str]
    rows: list[list[str | None]]
    schema_version: int = SCHEMA_VERSION


class TransactReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    ids: dict[str, str] = {}
    """Assigned ids of added elements, by ``ref`` (and by index ``"#<n>"`` of the op)."""
    duplicate: bool = False
    schema_version: int = SCHEMA_VERSION


class SnapshotReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    elements: list[Element]
    relations: list[Relation]
    classes: list[ClassDef] = []
    templates: list[TemplateDef] = []
    counters: dict[str, int] = {}
    schema_version: int = SCHEMA_VERSION
    ontology: list[OntologyDelta] = []
    """Everything the ontology gained beyond its core file, in order (classes, templates and
    taught terms); when set, ``classes`` and ``templates`` are left empty."""
    core_digest: str = ""
    """SHA-256 of the store's core ontology text: a client whose own core file differs
    fetches the store's with :class:`~wm_store.protocol.GetOntology`."""
    digest: str = ""
    """The store's chain digest at ``revision`` (see :class:`~wm_store.protocol.Change`)."""


class OntologyReply(Struct, tag=True, tag_field="reply", kw_only=True):
    """The store's ontology: its ``core`` Turtle text and what was taught since, in order."""

    revision: int
    core: str
    core_digest: str
    taught: list[OntologyDelta] = []
    schema_version: int = SCHEMA_VERSION


class CompiledOntologyReply(Struct, tag=True, tag_field="reply", kw_only=True):
    """The store's ontology at ``revision``, compiled: ``compiled`` is the msgpack of a
    ``wm_store.ontology`` compiled ontology (read it with ``Ontology.from_compiled``); it
    holds the core (of digest ``core_digest``) and the first ``taught`` deltas of the store's
    ontology log."""

    revision: int
    taught: int
    core_digest: str
    compiled: bytes
    schema_version: int = SCHEMA_VERSION


class ChangesReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    changes: list[Change]
    schema_version: int = SCHEMA_VERSION


class InfoReply(Struct, tag=True, tag_field="reply", kw_only=True):
    revision: int
    elements: int
    relations: int
    oldest_change: int
    durability: str
    data_dir: str
    started_at: float
    schema_version: int = SCHEMA_VERSION
    digest: str = ""
    """The chain digest at ``revision``: a replica at that revision with another digest
    diverged and reloads (see :class:`~wm_store.protocol.Change`)."""


class CardinalityViolation(Struct, frozen=True, kw_only=True):
    """``element`` (of class ``type``) has ``present`` ``relation`` triples (counting
    sub-properties, to objects of ``on_class`` if given) where its class requires at least
    ``required`` (a restriction declared on ``declared_on``, ``type`` or a superclass)."""

    element: str
    type: str
    relation: str
    required: int
    present: int
    on_class: str = ""
    declared_on: str = ""
    message: str = ""


class CardinalityReply(Struct, tag=True, tag_field="reply", kw_only=True):
    """The answer to :class:`CheckCardinality`: every violation, in element id order;
    ``checked`` is the number of elements the check covered."""

    revision: int
    checked: int
    violations: list[CardinalityViolation] = []
    schema_version: int = SCHEMA_VERSION


Reply: TypeAlias = (
    ElementsReply
    | RelationsReply
    | SparqlReply
    | TransactReply
    | SnapshotReply
    | ChangesReply
    | InfoReply
    | CardinalityReply
    | OntologyReply
    | CompiledOntologyReply
    | ErrorReply
)
