"""The change stream: the deltas of one committed transaction, published as a :class:`Change`."""

from __future__ import annotations

from typing import TypeAlias

from msgspec import Struct

from wm_store.protocol._values import (
    SCHEMA_VERSION,
    ClassDef,
    Element,
    Relation,
    TemplateDef,
    TermsDef,
)

# --------------------------------------------------------------------------- changes


class ElementPut(Struct, tag=True, tag_field="delta"):
    """The element as it is after the transaction (added or updated)."""

    element: Element


class ElementRemoved(Struct, tag=True, tag_field="delta"):
    id: str


class RelationAdded(Struct, tag=True, tag_field="delta"):
    relation: Relation


class RelationRemoved(Struct, tag=True, tag_field="delta"):
    relation: Relation


class ClassDefined(Struct, tag=True, tag_field="delta"):
    cls: ClassDef


class TemplateDefined(Struct, tag=True, tag_field="delta"):
    template: TemplateDef


class TermsDefined(Struct, tag=True, tag_field="delta"):
    terms: TermsDef


OntologyDelta: TypeAlias = ClassDefined | TemplateDefined | TermsDefined
"""A change to the ontology; the store's ontology is its core file plus these, in order."""

Delta: TypeAlias = (
    ElementPut
    | ElementRemoved
    | RelationAdded
    | RelationRemoved
    | ClassDefined
    | TemplateDefined
    | TermsDefined
)


class Change(Struct, kw_only=True):
    """One committed transaction: its revision and its effect, in order."""

    revision: int
    deltas: list[Delta]
    stamp: float
    txn_id: str = ""
    author: str = ""
    ids: dict[str, str] = {}
    """Ids assigned to added elements, by the ``ref`` the writer gave them."""
    schema_version: int = SCHEMA_VERSION
    digest: str = ""
    """The store's chain digest after this change (a hash of the previous digest and this
    change's deltas): two changes of one revision with different digests mean a replica
    applied one that did not come from the store."""
