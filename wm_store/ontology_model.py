"""The pieces :mod:`wm_store.ontology` is built from: info structs, the literal codec, and the
compiler that reads an rdflib graph once into plain declarations.

Nothing here walks the graph after loading: :func:`compile_graph` turns OWL/Turtle into
:class:`Declarations` (dicts of frozen structs), and :class:`wm_store.ontology.Ontology`
precomputes its closures from those.

Literal forms of the protocol values (:func:`literal_from_value`, :func:`value_from_literal`)::

    "0.1 0.2 0.3"^^skm:Position              x y z            (+ " @frame" if framed)
    "0 0 0 1"^^skm:Orientation               qx qy qz qw      (+ " @frame")
    "x y z qx qy qz qw"^^skm:Pose            pose             (+ " @frame")
    "m00 m01 ... m33"^^skm:Frame             16 numbers, row-major (+ " @frame")
    "0.3 0.2 0.1"^^skm:SizeCuboid  "r h"^^skm:SizeCylinder  "r"^^skm:SizeSphere
    "1 0 0 1"^^skm:Color                     r g b a in [0, 1]
    "[1.0, 2.0]"^^skm:json                   lists, null, and typed values with no compact form
    true / 3 / "2.5"^^xsd:double / "text"    bool, int, float, string

``literal_from_value`` then ``value_from_literal`` gives back an equal value (floats exactly:
numbers are written with ``repr``) for every value ``Ontology.check_value`` accepts; JSON
decoding also applies the protocol's own constraints (sizes >= 0, colour channels in [0, 1]).
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final, Literal, TypeAlias

import msgspec
from rdflib import OWL, RDF, RDFS, XSD, BNode, Graph, Namespace, URIRef
from rdflib import Literal as RdfLiteral
from rdflib.collection import Collection
from rdflib.term import Node

from wm_store.errors import OntologyError, PropertyValueError
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
    Value,
)

__all__ = [
    "ALL_KINDS",
    "SKM",
    "CardinalityRestriction",
    "CardinalityShortfall",
    "ClassInfo",
    "DataPropertyInfo",
    "Declarations",
    "RelationInfo",
    "Resolution",
    "compile_graph",
    "did_you_mean",
    "kind_of",
    "literal_from_value",
    "local_name",
    "typed_problem",
    "value_from_literal",
    "with_article",
]

SKM: Final = Namespace("https://skimesh.dev/ontology#")
"""The skimesh namespace; ontology IRI ``https://skimesh.dev/ontology``."""

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
CLASS_NAME_RE: Final = re.compile(r"[A-Z][A-Za-z0-9_]*")  # no '-': element ids are <Type>-<n>
TEMPLATE_NAME_RE: Final = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")


def with_article(name: str) -> str:
    """``a Gear``, ``an Arm``: the name with its indefinite article, for messages."""
    return f"{'an' if name[:1] in 'AEIOU' else 'a'} {name}"


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """``; did you mean 'X'?`` naming the closest candidates (case-insensitive first), else
    ``.``, to end an error message."""
    pool = sorted(candidates)
    folded = {c.lower(): c for c in pool}
    found = [folded[name.lower()]] if name.lower() in folded else []
    found = found or difflib.get_close_matches(name, pool, n=3, cutoff=0.6)
    if not found:
        return "."
    return "; did you mean " + " or ".join(f"'{m}'" for m in found) + "?"


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
    iris: dict[str, URIRef]
    """The IRI of every name (names are unique across namespaces and kinds)."""


# --------------------------------------------------------------------------- literal codec

_INT_TYPES: Final = frozenset(
    XSD[t]
    for t in [
        "integer",
        "int",
        "long",
        "short",
        "byte",
        "nonNegativeInteger",
        "positiveInteger",
        "negativeInteger",
        "nonPositiveInteger",
        "unsignedInt",
        "unsignedLong",
        "unsignedShort",
        "unsignedByte",
    ]
)
_FLOAT_TYPES: Final = frozenset({XSD.double, XSD.float, XSD.decimal})
_STRING_TYPES: Final = frozenset({XSD.string, RDF.PlainLiteral, RDF.langString, XSD.anyURI})
_FRAMED: Final = frozenset({"Position", "Orientation", "Pose", "Frame"})
_ARITY: Final[dict[str, tuple[int, ...]]] = {
    "Position": (3,),
    "Orientation": (4,),
    "Pose": (7,),
    "Frame": (16,),
    "SizeCuboid": (3,),
    "SizeCylinder": (2,),
    "SizeSphere": (1,),
    "Color": (4, 3),
}
_json_decoder: Final = msgspec.json.Decoder(Value)
_json_encoder: Final = msgspec.json.Encoder()


def _num(value: float) -> str:
    return repr(float(value))


def _compact(value: TypedValue) -> str | None:
    """The compact lexical form, or None when the value has none (then JSON is used)."""
    nums: tuple[float, ...]
    match value:
        case Position(x, y, z, frame):
            nums, frame_id = (x, y, z), frame
        case Orientation(x, y, z, w, frame):
            nums, frame_id = (x, y, z, w), frame
        case Pose(position, orientation, frame):
            if position.frame or orientation.frame:
                return None
            o = orientation
            nums, frame_id = (position.x, position.y, position.z, o.x, o.y, o.z, o.w), frame
        case Frame(matrix, frame):
            if len(matrix) != 16:
                return None
            nums, frame_id = tuple(matrix), frame
        case SizeCuboid(x, y, z):
            nums, frame_id = (x, y, z), ""
        case SizeCylinder(radius, height):
            nums, frame_id = (radius, height), ""
        case SizeSphere(radius):
            nums, frame_id = (radius,), ""
        case Color(r, g, b, a):
            nums, frame_id = (r, g, b, a), ""
    text = " ".join(_num(n) for n in nums)
    return f"{text} @{frame_id}" if frame_id else text


def literal_from_value(value: Value) -> RdfLiteral:
    """The RDF literal of a protocol value (compact typed forms, JSON for lists and None)."""
    if value is None or isinstance(value, list):
        return RdfLiteral(_json_encoder.encode(value).decode(), datatype=SKM.json)
    if isinstance(value, bool):
        return RdfLiteral("true" if value else "false", datatype=XSD.boolean)
    if isinstance(value, int):
        return RdfLiteral(str(value), datatype=XSD.integer)
    if isinstance(value, float):
        if math.isnan(value):
            return RdfLiteral("NaN", datatype=XSD.double)
        if math.isinf(value):
            return RdfLiteral("INF" if value > 0 else "-INF", datatype=XSD.double)
        return RdfLiteral(repr(value), datatype=XSD.double)
    if isinstance(value, str):
        return RdfLiteral(value)
    if type(value).__name__ not in TYPED_KINDS:
        raise PropertyValueError(f"{value!r} is not a world-model value (see wm_store.protocol)")
    compact = _compact(value)
    if compact is None:
        return RdfLiteral(_json_encoder.encode(value).decode(), datatype=SKM.json)
    return RdfLiteral(compact, datatype=SKM[type(value).__name__])


def _parse_compact(kind: str, text: str) -> TypedValue:
    head, sep, frame = text.partition("@")
    if sep and kind not in _FRAMED:
        raise PropertyValueError(f"a {kind} has no frame; remove '@{frame}' from {text!r}")
    try:
        n = [float(token) for token in head.split()]
    except ValueError:
        raise PropertyValueError(
            f"{text!r} is not a {kind}: write space-separated numbers"
        ) from None
    if len(n) not in _ARITY[kind]:
        want = " or ".join(str(a) for a in _ARITY[kind])
        raise PropertyValueError(f"a {kind} needs {want} numbers, {text!r} has {len(n)}")
    match kind:
        case "Position":
            return Position(n[0], n[1], n[2], frame)
        case "Orientation":
            return Orientation(n[0], n[1], n[2], n[3], frame)
        case "Pose":
            return Pose(Position(n[0], n[1], n[2]), Orientation(n[3], n[4], n[5], n[6]), frame)
        case "Frame":
            return Frame(tuple(n), frame)
        case "SizeCuboid":
            return SizeCuboid(n[0], n[1], n[2])
        case "SizeCylinder":
            return SizeCylinder(n[0], n[1])
        case "SizeSphere":
            return SizeSphere(n[0])
        case _:
            return Color(*n)


def value_from_literal(lit: Node) -> Value:
    """The protocol value of an RDF literal written by :func:`literal_from_value` (or by hand /
    Protégé with the usual xsd datatypes). Raises PropertyValueError for anything else."""
    if not isinstance(lit, RdfLiteral):
        raise PropertyValueError(f"expected a literal value, got the resource {lit}")
    text, dt = str(lit), lit.datatype
    if dt is None or dt in _STRING_TYPES:
        return text
    if dt == SKM.json:
        try:
            return _json_decoder.decode(text)  # type: ignore[no-any-return]
        except msgspec.DecodeError as exc:
            raise PropertyValueError(f"{text!r} is not a JSON world-model value: {exc}") from None
    if dt.startswith(SKM) and dt[len(SKM) :] in TYPED_KINDS:
        return _parse_compact(dt[len(SKM) :], text)
    try:
        if dt == XSD.boolean:
            if text.strip() in ("true", "1", "false", "0"):
                return text.strip() in ("true", "1")
            raise ValueError(text)
        if dt in _INT_TYPES:
            return int(text)
        if dt in _FLOAT_TYPES:
            return float(text)
    except ValueError:
        raise PropertyValueError(f"{text!r} is not a valid {local_name(dt)}") from None
    raise PropertyValueError(
        f"unsupported datatype {dt} for {text!r}; use an xsd number/boolean/string type, "
        "a skm typed-value datatype (skm:Pose, skm:SizeCuboid, ...) or skm:json"
    )


# --------------------------------------------------------------------------- value checks

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


def _is(obj: object, cls: type) -> bool:
    """isinstance, for fields whose declared type a caller may not have respected."""
    return isinstance(obj, cls)


def _bad_numbers(nums: tuple[object, ...], low: float | None, high: float | None) -> bool:
    return not all(
        isinstance(n, int | float)
        and not isinstance(n, bool)
        and math.isfinite(n)
        and (low is None or n >= low)
        and (high is None or n <= high)
        for n in nums
    )


def typed_problem(value: TypedValue) -> str | None:
    """What is wrong inside a typed value (non-finite numbers, negative sizes, colour channels
    outside [0, 1], a Frame without 16 numbers, a frame that is not a string), or None."""
    frames: tuple[object, ...] = ()
    match value:
        case Position(x, y, z, frame):
            bad, frames = _bad_numbers((x, y, z), None, None), (frame,)
        case Orientation(x, y, z, w, frame):
            bad, frames = _bad_numbers((x, y, z, w), None, None), (frame,)
        case Pose(position, orientation, frame):
            if not (_is(position, Position) and _is(orientation, Orientation)):
                return "a Pose holds a Position and an Orientation"
            inner = typed_problem(position) or typed_problem(orientation)
            if inner:
                return inner
            bad, frames = False, (frame,)
        case Frame(matrix, frame):
            if len(matrix) != 16:
                return f"a Frame needs 16 numbers (row-major 4x4), got {len(matrix)}"
            bad, frames = _bad_numbers(tuple(matrix), None, None), (frame,)
        case SizeCuboid(x, y, z):
            bad = _bad_numbers((x, y, z), 0.0, None)
        case SizeCylinder(radius, height):
            bad = _bad_numbers((radius, height), 0.0, None)
        case SizeSphere(radius):
            bad = _bad_numbers((radius,), 0.0, None)
        case Color(r, g, b, a):
            bad = _bad_numbers((r, g, b, a), 0.0, 1.0)
            if bad:
                return f"colour channels must be numbers in [0, 1]: {value!r}"
    if bad:
        low = " >= 0" if kind_of(value) in ("SizeCuboid", "SizeCylinder", "SizeSphere") else ""
        return f"{type(value).__name__} needs finite numbers{low}: {value!r}"
    if not all(isinstance(f, str) for f in frames):
        return f"the frame of {value!r} must be an element id (a string)"
    return None


# --------------------------------------------------------------------------- graph compiler

_RESERVED: Final = (str(OWL), str(RDF), str(RDFS), str(XSD))
_DATATYPE_KINDS: Final[dict[URIRef, frozenset[str]]] = {
    **{t: frozenset({"int"}) for t in _INT_TYPES},
    **{t: frozenset({"float"}) for t in _FLOAT_TYPES},
    **{t: frozenset({"string"}) for t in _STRING_TYPES},
    XSD.boolean: frozenset({"bool"}),
    RDFS.Literal: ALL_KINDS,
    SKM.json: frozenset({"list"}),
    **{SKM[k]: frozenset({k}) for k in TYPED_KINDS},
}
_IMPLIED_MINIMUM: Final = {XSD.nonNegativeInteger: 0.0, XSD.positiveInteger: 1.0}


def local_name(iri: str) -> str:
    """``https://skimesh.dev/ontology#Gear`` -> ``Gear`` (after ``#``, else the last ``/``)."""
    return iri.rsplit("#", 1)[-1] if "#" in iri else iri.rstrip("/").rsplit("/", 1)[-1]


class _Reader:
    """Reads one graph; every error names the entity and says how to fix it."""

    def __init__(self, graph: Graph) -> None:
        self.g = graph
        self.names: dict[str, tuple[str, URIRef]] = {}
        self.classes = self._declared("class", (OWL.Class, RDFS.Class), CLASS_NAME_RE)
        self.relations = self._declared("object property", (OWL.ObjectProperty,), NAME_RE)
        self.data_props = self._declared("data property", (OWL.DatatypeProperty,), NAME_RE)
        self.datatypes = self._declared("datatype", (RDFS.Datatype,), NAME_RE)
        self.annotations = set(self.g.subjects(RDF.type, OWL.AnnotationProperty))

    def _declared(
        self, kind: str, types: tuple[URIRef, ...], pattern: re.Pattern[str]
    ) -> dict[URIRef, str]:
        found: dict[URIRef, str] = {}
        for t in types:
            for s in self.g.subjects(RDF.type, t):
                if isinstance(s, URIRef) and not str(s).startswith(_RESERVED):
                    found[s] = self._register(s, kind, pattern)
        return found

    def _register(self, iri: URIRef, kind: str, pattern: re.Pattern[str]) -> str:
        name = local_name(iri)
        if not pattern.fullmatch(name):
            rule = "a capital letter" if pattern is CLASS_NAME_RE else "a letter"
            more = ", '-'" if pattern is TEMPLATE_NAME_RE else ""
            raise OntologyError(
                f"{kind} <{iri}>: the name {name!r} must start with {rule} and contain only "
                f"letters, digits{more} and '_' (element ids are '<Type>-<n>'); rename it"
            )
        seen = self.names.get(name)
        if seen is not None and seen[1] != iri:
            raise OntologyError(
                f"the name {name!r} is used twice: {seen[0]} <{seen[1]}> and {kind} <{iri}>; "
                "names must be unique across namespaces and across classes, properties, "
                "datatypes and templates"
            )
        self.names[name] = (kind, iri)
        return name

    def text(self, s: Node, p: URIRef) -> str:
        values = [o for o in self.g.objects(s, p) if isinstance(o, RdfLiteral)]
        for want in ("en", None):
            for o in values:
                if o.language == want:
                    return str(o)
        return str(values[0]) if values else ""

    def flag(self, s: Node, p: URIRef) -> bool | None:
        """A boolean annotation: None when absent; ``true`` or the string "true" is True."""
        o = self.g.value(s, p)
        if o is None:
            return None
        value = value_from_literal(o)
        return value is True or (isinstance(value, str) and value.strip().lower() == "true")

    def class_ref(self, node: Node, where: str) -> str | None:
        if node == OWL.Thing:
            return None
        if isinstance(node, URIRef) and node in self.classes:
            return self.classes[node]
        hint = did_you_mean(local_name(str(node)), self.classes.values())
        raise OntologyError(
            f"{where}: {node} is not a declared owl:Class{hint} (or add its "
            "'rdf:type owl:Class' declaration)"
        )

    def class_set(self, s: URIRef, p: URIRef, where: str) -> frozenset[str]:
        nodes = list(self.g.objects(s, p))
        if len(nodes) > 1:
            raise OntologyError(
                f"{where} has {len(nodes)} {local_name(p)} statements (OWL reads that as an "
                "intersection); state one, using owl:unionOf for alternatives"
            )
        if not nodes:
            return frozenset()
        node = nodes[0]
        members = self.g.value(node, OWL.unionOf) if isinstance(node, BNode) else None
        if members is not None:
            refs = (self.class_ref(m, where) for m in Collection(self.g, members))
            return frozenset(r for r in refs if r is not None)
        ref = self.class_ref(node, where)
        return frozenset() if ref is None else frozenset({ref})

    def superproperties(self, s: URIRef, declared: dict[URIRef, str], where: str) -> list[str]:
        out = []
        for o in self.g.objects(s, RDFS.subPropertyOf):
            if o in (OWL.topObjectProperty, OWL.topDataProperty):
                continue
            if not isinstance(o, URIRef) or o not in declared:
                raise OntologyError(f"{where}: super-property {o} is not declared")
            out.append(declared[o])
        return sorted(out)


def _closure(parents: dict[str, list[str]], name: str) -> set[str]:
    seen: set[str] = set()
    todo = list(parents.get(name, ()))
    while todo:
        p = todo.pop()
        if p == name:
            raise OntologyError(f"'{name}' is its own super-property; break the cycle")
        if p not in seen:
            seen.add(p)
            todo.extend(parents.get(p, ()))
    return seen


def _read_relations(r: _Reader) -> dict[str, RelationInfo]:
    parents = {
        name: r.superproperties(iri, r.relations, f"relation '{name}'")
        for iri, name in r.relations.items()
    }
    spatial_root = local_name(SKM.spatialRelation)
    marked = {name for iri, name in r.relations.items() if r.flag(iri, SKM.spatial)}
    out: dict[str, RelationInfo] = {}
    for iri, name in r.relations.items():
        ancestors = _closure(parents, name) | {name}
        spatial = spatial_root in ancestors or bool(ancestors & marked)
        if r.flag(iri, SKM.spatial) is False and spatial:
            raise OntologyError(
                f"relation '{name}' is annotated skm:spatial false but is a sub-property of a "
                "spatial relation; remove the annotation or the rdfs:subPropertyOf"
            )
        domains = r.class_set(iri, RDFS.domain, f"relation '{name}'")
        ranges = r.class_set(iri, RDFS.range, f"relation '{name}'")
        out[name] = RelationInfo(
            name=name,
            domain=next(iter(domains)) if len(domains) == 1 else None,
            range=next(iter(ranges)) if len(ranges) == 1 else None,
            spatial=spatial,
            parents=tuple(parents[name]),
            label=r.text(iri, RDFS.label),
            comment=r.text(iri, RDFS.comment),
            domains=domains,
            ranges=ranges,
            abstract=bool(r.flag(iri, SKM.abstract)),
        )
    return out


def _number(node: Node | None, where: str) -> float:
    value = value_from_literal(node) if node is not None else None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise OntologyError(f"{where}: expected a number, got {node}")
    return float(value)


def _read_range(
    r: _Reader, node: Node, where: str
) -> tuple[frozenset[str], float | None, float | None]:
    """Kinds, minimum and maximum of an rdfs:range (datatype, restriction or union)."""
    if isinstance(node, URIRef):
        if node not in _DATATYPE_KINDS:
            raise OntologyError(
                f"{where}: unsupported range {node}; use xsd:double/integer/boolean/string, "
                "a skm typed-value datatype, skm:json or rdfs:Literal"
            )
        return _DATATYPE_KINDS[node], _IMPLIED_MINIMUM.get(node), None
    union = r.g.value(node, OWL.unionOf)
    if union is not None:
        kinds = frozenset().union(*(_read_range(r, m, where)[0] for m in Collection(r.g, union)))
        return kinds, None, None
    base = r.g.value(node, OWL.onDatatype)
    if base is None:
        raise OntologyError(f"{where}: a range must be a datatype, a restriction or a union")
    kinds, minimum, maximum = _read_range(r, base, where)
    facets = r.g.value(node, OWL.withRestrictions)
    for facet in Collection(r.g, facets) if facets is not None else ():
        for p, o in r.g.predicate_objects(facet):
            if p == XSD.minInclusive:
                minimum = _number(o, where)
            elif p == XSD.maxInclusive:
                maximum = _number(o, where)
            else:
                raise OntologyError(
                    f"{where}: facet {local_name(str(p))} is not supported; use minInclusive / "
                    "maxInclusive (with skm:tolerance for measurement noise)"
                )
    return kinds, minimum, maximum


def _read_data_property(r: _Reader, iri: URIRef, name: str) -> DataPropertyInfo:
    where = f"data property '{name}'"
    ranges = list(r.g.objects(iri, RDFS.range))
    if len(ranges) > 1:
        raise OntologyError(f"{where} has {len(ranges)} rdfs:range statements; state one")
    range_kinds, minimum, maximum = (
        _read_range(r, ranges[0], where) if ranges else (ALL_KINDS, None, None)
    )
    kinds = range_kinds
    declared = [str(o) for o in r.g.objects(iri, SKM.valueKind)]
    if declared:
        unknown = [k for k in declared if k not in ALL_KINDS and k not in KIND_ALIASES]
        if unknown:
            raise OntologyError(
                f"{where}: unknown skm:valueKind {unknown}; use one of "
                f"{sorted(ALL_KINDS | KIND_ALIASES.keys())}"
            )
        kinds = frozenset().union(*(KIND_ALIASES.get(k, frozenset({k})) for k in declared))
        widened = range_kinds | ({"float"} if "int" in range_kinds else set())
        if not kinds <= widened and range_kinds != frozenset({"list"}):
            raise OntologyError(
                f"{where}: skm:valueKind {sorted(kinds)} does not fit its rdfs:range "
                f"({sorted(range_kinds)}); make them agree"
            )
    numeric = bool(kinds & {"float", "int"})
    if (minimum is not None or maximum is not None) and not numeric:
        raise OntologyError(f"{where}: a numeric range needs a numeric kind, not {sorted(kinds)}")
    if minimum is not None and maximum is not None and minimum > maximum:
        raise OntologyError(f"{where}: minimum {minimum} is above maximum {maximum}")
    tol_node = r.g.value(iri, SKM.tolerance)
    tolerance = _number(tol_node, where) if tol_node is not None else 0.0
    if tolerance < 0 or not math.isfinite(tolerance):
        raise OntologyError(f"{where}: skm:tolerance must be a finite number >= 0")
    resolution = str(r.g.value(iri, SKM.resolution) or "latest")
    if resolution not in RESOLUTIONS:
        raise OntologyError(f"{where}: skm:resolution {resolution!r} is not one of {RESOLUTIONS}")
    if resolution == "fused" and not (kinds - {"list"}) <= FUSABLE_KINDS:
        raise OntologyError(
            f"{where}: 'fused' needs numbers or positions, not {sorted(kinds)}; "
            "use 'most_confident'"
        )
    domains = r.class_set(iri, RDFS.domain, where)
    return DataPropertyInfo(
        name=name,
        kinds=kinds,
        minimum=minimum,
        maximum=maximum,
        tolerance=tolerance,
        resolution=resolution,  # type: ignore[arg-type]
        domain=next(iter(domains)) if len(domains) == 1 else None,
        label=r.text(iri, RDFS.label),
        comment=r.text(iri, RDFS.comment),
        domains=domains,
    )


_CARDINALITY: Final = {
    OWL.maxCardinality: (False, True),
    OWL.minCardinality: (True, False),
    OWL.cardinality: (True, True),
    OWL.maxQualifiedCardinality: (False, True),
    OWL.minQualifiedCardinality: (True, False),
    OWL.qualifiedCardinality: (True, True),
}


def _read_restrictions(r: _Reader) -> list[CardinalityRestriction]:
    out = []
    for iri, cls in r.classes.items():
        for node in r.g.objects(iri, RDFS.subClassOf):
            if not isinstance(node, BNode) or (node, RDF.type, OWL.Restriction) not in r.g:
                continue
            where = f"restriction on class '{cls}'"
            prop = r.g.value(node, OWL.onProperty)
            if prop in r.data_props:
                continue  # data properties hold one value per element anyway
            if not isinstance(prop, URIRef) or prop not in r.relations:
                raise OntologyError(f"{where}: owl:onProperty {prop} is not a declared relation")
            on_node = r.g.value(node, OWL.onClass)
            on_class = r.class_ref(on_node, where) if on_node is not None else None
            lo: int | None = None
            hi: int | None = None
            some = r.g.value(node, OWL.someValuesFrom)
            if some is not None:  # "hasA some Arm" is "hasA min 1 Arm"
                on_class, lo, hi = r.class_ref(some, where), 1, None
            else:
                for p, (is_min, is_max) in _CARDINALITY.items():
                    o = r.g.value(node, p)
                    if o is not None:
                        n = int(_number(o, where))
                        lo, hi = (n if is_min else lo), (n if is_max else hi)
                if lo is None and hi is None:
                    continue  # allValuesFrom, hasValue...: not enforced
            rel = r.relations[prop]
            out.append(
                CardinalityRestriction(
                    declared_on=cls, relation=rel, minimum=lo, maximum=hi, on_class=on_class
                )
            )
    return out


def _read_templates(r: _Reader) -> dict[str, TemplateDef]:
    skip = {RDF.type, RDFS.label, RDFS.comment, SKM.template, *r.annotations}
    out: dict[str, TemplateDef] = {}
    for s in r.g.subjects(SKM.template, None):
        if not isinstance(s, URIRef) or not r.flag(s, SKM.template):
            continue
        name = r._register(s, "template", TEMPLATE_NAME_RE)
        where = f"template '{name}'"
        types = sorted(
            r.classes[t]
            for t in r.g.objects(s, RDF.type)
            if isinstance(t, URIRef) and t in r.classes
        )
        if len(types) != 1:
            raise OntologyError(f"{where} must have exactly one class as rdf:type, has {types}")
        props: dict[str, Value] = {}
        for p, o in r.g.predicate_objects(s):
            if not isinstance(p, URIRef) or p in skip:
                continue
            if p in r.relations:
                raise OntologyError(f"{where}: templates carry data properties, not relations")
            if p not in r.data_props:
                if str(p).startswith((str(SKM), str(s)[: len(s) - len(name)])):
                    raise OntologyError(
                        f"{where}: {p} is not a declared data property (a typo?); "
                        f"data properties: {sorted(r.data_props.values())}"
                    )
                continue  # foreign annotations (dc:creator, ...) are not ours to read
            key = r.data_props[p]
            if key in props:
                raise OntologyError(f"{where}: '{key}' has two values; give one")
            try:
                props[key] = value_from_literal(o)
            except PropertyValueError as exc:
                raise OntologyError(f"{where}, property '{key}': {exc}") from None
        out[name] = TemplateDef(
            name=name, type=types[0], label=r.text(s, RDFS.label), properties=props
        )
    return out


def compile_graph(graph: Graph) -> Declarations:
    """Read classes, relations, data properties, cardinalities and templates from ``graph``.

    Raises OntologyError naming the entity at fault (undeclared parent, bad name, unsupported
    range, duplicate name, ...)."""
    r = _Reader(graph)
    classes: dict[str, ClassInfo] = {}
    for iri, name in r.classes.items():
        parents = (
            r.class_ref(o, f"class '{name}'")
            for o in graph.objects(iri, RDFS.subClassOf)
            if isinstance(o, URIRef)
        )
        classes[name] = ClassInfo(
            name=name,
            parents=tuple(sorted(p for p in parents if p is not None)),
            label=r.text(iri, RDFS.label),
            comment=r.text(iri, RDFS.comment),
        )
    return Declarations(
        classes=classes,
        relations=_read_relations(r),
        data_properties={n: _read_data_property(r, i, n) for i, n in r.data_props.items()},
        restrictions=tuple(_read_restrictions(r)),
        templates=_read_templates(r),
        datatypes=frozenset(r.datatypes.values()),
        iris={name: iri for name, (_, iri) in r.names.items()},
    )
