"""Transaction ops: what a :class:`~wm_store.protocol.Transact` request applies, all or none."""

from __future__ import annotations

from typing import Literal, TypeAlias

from msgspec import Struct

from wm_store.protocol._values import ClassDef, Relation, TemplateDef, TermsDef, Unit, Value

# --------------------------------------------------------------------------- transaction ops


class AddElement(Struct, tag=True, tag_field="op", kw_only=True):
    """Add an element. ``ref`` (e.g. ``"$box"``) names it inside the transaction so relations
    and later ops can point at it before its id exists; the reply maps refs to assigned ids.
    ``id`` may be given explicitly (``<type>-<n>``) to restore an exported scene; it must be
    one the store never used."""

    type: str
    label: str = ""
    properties: dict[str, Value] = {}
    relations: list[Relation] = []
    ref: str = ""
    id: str = ""


class UpdateElement(Struct, tag=True, tag_field="op", kw_only=True):
    """Change properties (``merge`` keeps the others, ``replace`` drops them) and/or label."""

    id: str
    properties: dict[str, Value] = {}
    remove: list[str] = []
    mode: Literal["merge", "replace"] = "merge"
    label: str | None = None
    expect_rev: int | None = None


class Observe(Struct, tag=True, tag_field="op", kw_only=True):
    """Record ``source``'s observation of a property; the resolved value is recomputed."""

    id: str
    property: str
    value: Value
    source: str
    confidence: Unit = 1.0
    stamp: float | None = None


class RemoveElement(Struct, tag=True, tag_field="op", kw_only=True):
    """Remove an element (``branch=True``: with everything it spatially contains)."""

    id: str
    branch: bool = False
    expect_rev: int | None = None


class SetRelation(Struct, tag=True, tag_field="op", kw_only=True):
    subject: str
    predicate: str
    object: str


class UnsetRelation(Struct, tag=True, tag_field="op", kw_only=True):
    subject: str
    predicate: str
    object: str


class DefineClass(Struct, tag=True, tag_field="op", kw_only=True):
    """Extend the ontology with a new class while the system runs."""

    cls: ClassDef


class DefineTemplate(Struct, tag=True, tag_field="op", kw_only=True):
    """Add (or replace) a default individual."""

    template: TemplateDef


class DefineTerms(Struct, tag=True, tag_field="op", kw_only=True):
    """Teach the ontology terms written in Turtle (classes, relations, data properties,
    restrictions, templates). Additive and idempotent: terms the ontology already has change
    nothing, and a transaction of such ops commits no revision."""

    terms: TermsDef


Op: TypeAlias = (
    AddElement
    | UpdateElement
    | Observe
    | RemoveElement
    | SetRelation
    | UnsetRelation
    | DefineClass
    | DefineTemplate
    | DefineTerms
)
