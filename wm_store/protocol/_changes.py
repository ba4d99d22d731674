"""The change stream: the deltas of one committed transaction, published as a :class:`Change`."""

from __future__ import annotations

from typing import TypeAlias

from msgspec import Struct

from wm_store.protocol._values import SCHEMA_VERSION, ClassDef, Element, Relation, TemplateDef

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


Delta: TypeAlias = (
    ElementPut | ElementRemoved | RelationAdded | RelationRemoved | ClassDefined | TemplateDefined
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
