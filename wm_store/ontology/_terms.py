"""The vocabulary the ontology modules share (without rdflib): the value kinds a data
property can take, the rules for names, the helpers that word error messages, and the frozen
info structs an ontology is declared as.

:class:`Declarations` is what :func:`wm_store.ontology._model.compile_graph` reads from a graph
(dicts of :class:`ClassInfo`, :class:`RelationInfo`, :class:`DataPropertyInfo`, plus cardinality
restrictions and templates); :class:`wm_store.ontology.Ontology` precomputes its closures from
it. Nothing here reads a graph.

Messages name the closest known name (:func:`did_you_mean`) and point to the guide
(:data:`EXTEND_GUIDE`) where the fix is an ontology change.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final, Literal, TypeAlias

import msgspec

from wm_store.protocol import (
    Color,
    Frame,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    TemplateDef,
    TypedValue,
)

__all__ = [
    "ALL_KINDS",
    "CardinalityRestriction",
    "CardinalityShortfall",
    "ClassInfo",
    "DataPropertyInfo",
    "Declarations",
    "RelationInfo",
    "Resolution",
    "did_you_mean",
    "kind_of",
    "local_name",
    "one_of",
    "with_article",
]

Resolution: TypeAlias = Literal["latest", "most_confident", "fused"]
RESOLUTIONS: Final = ("latest", "most_confident", "fused")

TYPED_KINDS: Final[dict[str, type[TypedValue]]] = {
    "Position": Position,
    "Orientation": Orientation,
    "Pose": Pose,
    "Frame": Frame,
    "SizeCuboid": SizeCuboid,
    "SizeCylinder": SizeCylinder,
    "SizeSphere": SizeSphere,
    "Color": Color,
}
SCALAR_KINDS: Final = frozenset({"float", "int", "bool", "string", *TYPED_KINDS})
ALL_KINDS: Final = SCALAR_KINDS | {"list"}
"""Every value kind a data property can take (``skm:valueKind``)."""
KIND_ALIASES: Final[dict[str, frozenset[str]]] = {
    "Size": frozenset({"SizeCuboid", "SizeCylinder", "SizeSphere"}),
    "any": ALL_KINDS,
}
FUSABLE_KINDS: Final = frozenset({"float", "int", "Position"})

NAME_RE: Final = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
SKM_IRI: Final = "https://skimesh.dev/ontology#"
"""The skimesh namespace, as a string (:data:`~wm_store.ontology.NAMESPACE` is its rdflib
form)."""
CLASS_NAME_RE: Final = re.compile(r"[A-Z][A-Za-z0-9_]*")  # no '-': element ids are <Type>-<n>
TEMPLATE_NAME_RE: Final = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")

EXTEND_GUIDE: Final = "docs/guides/extend-the-ontology.md"
WHERE_TERMS: Final = (
    "The world model's ontology is its core plus what was taught: files given to "
    "`skimesh wm --ontology`, a scenario's `ontology` files, agents' and skills' `ontology` "
    f"files, and `skimesh wm teach` / `define-class` / `define-property` ({EXTEND_GUIDE})"
)
"""Where terms come from, for the errors about an unknown one."""
"""Where error messages send a reader who has to change the ontology."""

# --------------------------------------------------------------------------- names in messages


def local_name(iri: str) -> str:
    """``https://skimesh.dev/ontology#Gear`` -> ``Gear`` (after ``#``, else the last ``/``)."""
    return iri.rsplit("#", 1)[-1] if "#" in iri else iri.rstrip("/").rsplit("/", 1)[-1]


def with_article(name: str) -> str:
    """``a Gear``, ``an Arm``: the name with its indefinite article, for messages."""
    return f"{'an' if name[:1] in 'AEIOU' else 'a'} {name}"


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """``; did you mean 'X'?`` naming the closest candidates (case-insensitive first), else
    ``.``, to end an error message. Each name is suggested once, however often ``candidates``
    holds it; give only names of the kind asked for (elements for an element, classes for a
    class), so the suggestion can stand where the unknown name stood."""
    pool = sorted(set(candidates))
    folded = {c.lower(): c for c in pool}
    found = [folded[name.lower()]] if name.lower() in folded else []
    found = found or difflib.get_close_matches(name, pool, n=3, cutoff=0.6)
    if not found:
        return "."
    return "; did you mean " + " or ".join(f"'{m}'" for m in found) + "?"


def one_of(names: Iterable[str]) -> str:
    """``Gear``, or ``one of Arm, Gear``: the allowed names, for messages."""
    items = sorted(names)
    return items[0] if len(items) == 1 else "one of " + ", ".join(items)


# --------------------------------------------------------------------------- info structs


class ClassInfo(msgspec.Struct, frozen=True, kw_only=True):
    """A class as declared: its direct parents (``rdfs:subClassOf``), label and comment."""

    name: str
    parents: tuple[str, ...] = ()
    label: str = ""
    comment: str = ""


class RelationInfo(msgspec.Struct, frozen=True, kw_only=True):
    """An object property.

    ``domains`` / ``ranges`` are the classes the subject / object must belong to (one of
    them; empty: any class). ``domain`` / ``range`` name the class when there is exactly one,
    else ``None`` (no restriction, or a union: see ``domains``). ``parents`` are the direct
    super-properties. ``spatial`` relations point parent -> child and form a tree. An
    ``abstract`` relation only groups its sub-properties and cannot be set directly.
    """

    name: str
    domain: str | None = None
    range: str | None = None
    spatial: bool = False
    parents: tuple[str, ...] = ()
    label: str = ""
    comment: str = ""
    domains: frozenset[str] = frozenset()
    ranges: frozenset[str] = frozenset()
    abstract: bool = False


class DataPropertyInfo(msgspec.Struct, frozen=True, kw_only=True):
    """A data property: the kinds of value it takes, its numeric range and tolerance, and how
    observations from several sources are resolved into one value."""

    name: str
    kinds: frozenset[str] = ALL_KINDS
    minimum: float | None = None
    maximum: float | None = None
    tolerance: float = 0.0
    resolution: Resolution = "latest"
    domain: str | None = None
    label: str = ""
    comment: str = ""
    domains: frozenset[str] = frozenset()


class CardinalityRestriction(msgspec.Struct, frozen=True, kw_only=True):
    """``declared_on`` has at least ``minimum`` / at most ``maximum`` ``relation`` triples
    (counting sub-properties), to objects of ``on_class`` if given (qualified)."""

    declared_on: str
    relation: str
    minimum: int | None = None
    maximum: int | None = None
    on_class: str | None = None

    def describe(self) -> str:
        target = f" to {with_article(self.on_class)}" if self.on_class else ""
        if self.minimum is not None and self.minimum == self.maximum:
            bound = f"exactly {self.minimum}"
        elif self.maximum is not None and self.minimum:
            bound = f"{self.minimum} to {self.maximum}"
        elif self.maximum is not None:
            bound = f"at most {self.maximum}"
        else:
            bound = f"at least {self.minimum}"
        return f"{bound} '{self.relation}'{target} (declared on {self.declared_on})"


class CardinalityShortfall(msgspec.Struct, frozen=True, kw_only=True):
    """An element has fewer relations than a minimum cardinality asks for."""

    restriction: CardinalityRestriction
    actual: int
    message: str


@dataclass(frozen=True)
class Declarations:
    """Everything read from the graph, keyed by local name. Treated as immutable."""

    classes: dict[str, ClassInfo]
    relations: dict[str, RelationInfo]
    data_properties: dict[str, DataPropertyInfo]
    restrictions: tuple[CardinalityRestriction, ...]
    templates: dict[str, TemplateDef]
    datatypes: frozenset[str]
    iris: dict[str, str]
    """The IRI of every name (names are unique across namespaces and kinds)."""


_KIND_OF_TYPE: Final[dict[type, str]] = {t: k for k, t in TYPED_KINDS.items()}


def kind_of(value: object) -> str | None:
    """The value kind of a scalar (``bool`` is not an ``int`` here), or None."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "string"
    return _KIND_OF_TYPE.get(type(value))
