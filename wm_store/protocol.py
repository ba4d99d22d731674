"""Wire schema of the world model: values, elements, transactions, requests, replies, changes.

Everything that crosses the ``wm_store`` boundary is one of these msgspec Structs, encoded as
MessagePack. Unions are tagged (``tag=True``), so a decoder built once dispatches on the tag.
Wire messages only ever gain fields *with defaults*, so an older client still talks to a newer
store; ``schema_version`` says which version wrote a message.

Key space (prefix ``skimesh/<mesh>``):

- ``wm/rpc``            queryable, one :data:`Request` in, one :data:`Reply` out
- ``wm/query``          the same, read-only (every request but :class:`Transact`)
- ``wm/changes``        publication, one :class:`Change` per committed transaction
- ``wm/elements/<id>``  storage-style get: each element as JSON, for any Zenoh tool
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, TypeAlias

import msgspec
from msgspec import Meta, Struct

__all__ = [
    "SCHEMA_VERSION",
    "AddElement",
    "CardinalityReply",
    "CardinalityViolation",
    "Change",
    "ChangesReply",
    "ChangesSince",
    "CheckCardinality",
    "ClassDef",
    "ClassDefined",
    "Color",
    "DefineClass",
    "DefineTemplate",
    "Delta",
    "Element",
    "ElementPut",
    "ElementRemoved",
    "ElementsReply",
    "ErrorReply",
    "Frame",
    "GetElements",
    "Info",
    "InfoReply",
    "Observation",
    "Observe",
    "Op",
    "Orientation",
    "Parent",
    "Pose",
    "Position",
    "PropertyFilter",
    "Query",
    "Relation",
    "RelationAdded",
    "RelationRemoved",
    "Relations",
    "RelationsReply",
    "RemoveElement",
    "Reply",
    "Request",
    "Resolve",
    "SetRelation",
    "SizeCuboid",
    "SizeCylinder",
    "SizeSphere",
    "Snapshot",
    "SnapshotReply",
    "Sparql",
    "SparqlReply",
    "Struct_",
    "TemplateDef",
    "TemplateDefined",
    "Transact",
    "TransactReply",
    "TypedValue",
    "UnsetRelation",
    "UpdateElement",
    "Value",
    "decode_change",
    "decode_reply",
    "decode_request",
    "encode",
]

SCHEMA_VERSION = 1

Struct_ = Struct  # re-exported for plug-ins that define their own typed data

Finite = Annotated[float, Meta(description="a finite float")]
NonNeg = Annotated[float, Meta(ge=0.0)]
Unit = Annotated[float, Meta(ge=0.0, le=1.0)]

# --------------------------------------------------------------------------- typed values
# The typed sub-symbolic data of FRIEND II. All tagged, all frozen (values are immutable).


class Position(Struct, tag=True, frozen=True):
    """A point in metres, expressed in ``frame`` (an element id, or "" for the world)."""

    x: float
    y: float
    z: float
    frame: str = ""


class Orientation(Struct, tag=True, frozen=True):
    """A unit quaternion (x, y, z, w), expressed in ``frame``."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0
    frame: str = ""


class Pose(Struct, tag=True, frozen=True):
    """Position and orientation of an element relative to ``frame``."""

    position: Position
    orientation: Orientation = Orientation()
    frame: str = ""


class Frame(Struct, tag=True, frozen=True):
    """A homogeneous transform, 16 floats row-major (FRIEND II ``Frame``)."""

    matrix: tuple[float, ...]
    frame: str = ""


class SizeCuboid(Struct, tag=True, frozen=True):
    x: NonNeg
    y: NonNeg
    z: NonNeg


class SizeCylinder(Struct, tag=True, frozen=True):
    radius: NonNeg
    height: NonNeg


class SizeSphere(Struct, tag=True, frozen=True):
    radius: NonNeg


class Color(Struct, tag=True, frozen=True):
    """RGBA, each channel in [0, 1]."""

    r: Unit
    g: Unit
    b: Unit
    a: Unit = 1.0


TypedValue: TypeAlias = (
    Position | Orientation | Pose | Frame | SizeCuboid | SizeCylinder | SizeSphere | Color
)
Scalar: TypeAlias = bool | int | float | str | TypedValue
Value: TypeAlias = Scalar | list[Scalar] | None
"""What a property holds: a plain value, a typed value, or a list of them."""


class Observation(Struct, frozen=True, kw_only=True):
    """One source's report of a property value (provenance).

    Several sources may report the same property; the element's ``properties`` holds the value
    chosen by the property's resolution policy, and the observations stay queryable.
    """

    value: Value
    source: str
    stamp: float
    confidence: Unit = 1.0


# --------------------------------------------------------------------------- scene graph


class Element(Struct, kw_only=True):
    """A node of the scene graph.

    ``id`` is assigned by the store (``<Type>-<n>``, never reused); ``rev`` is the store
    revision that last changed this element; ``updated_at`` the wall-clock time of that change.
    """

    id: str
    type: str
    label: str = ""
    properties: dict[str, Value] = {}
    observations: dict[str, list[Observation]] = {}
    rev: int = 0
    updated_at: float = 0.0


class Relation(Struct, frozen=True):
    """A triple ``(subject, predicate, object)``; the predicate is an ontology relation."""

    subject: str
    predicate: str
    object: str


class ClassDef(Struct, frozen=True, kw_only=True):
    """A class taught at run time: ``name`` becomes a subclass of ``parent``."""

    name: str
    parent: str
    label: str = ""
    comment: str = ""


class TemplateDef(Struct, frozen=True, kw_only=True):
    """A default individual: a named template with default properties (SkiROS
    ``getDefaultElement``)."""

    name: str
    type: str
    label: str = ""
    properties: dict[str, Value] = {}


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


Op: TypeAlias = (
    AddElement
    | UpdateElement
    | Observe
    | RemoveElement
    | SetRelation
    | UnsetRelation
    | DefineClass
    | DefineTemplate
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
)

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


class ErrorReply(Struct, tag=True, tag_field="reply", kw_only=True):
    """The request was refused; nothing changed. ``code`` is the error class's code."""

    code: str
    message: str
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
    | ErrorReply
)

# --------------------------------------------------------------------------- codecs
# Built once (msgspec perf tip); decoders are thread-safe.

_encoder = msgspec.msgpack.Encoder()
_request_decoder = msgspec.msgpack.Decoder(Request)
_reply_decoder = msgspec.msgpack.Decoder(Reply)
_change_decoder = msgspec.msgpack.Decoder(Change)


def encode(message: Any) -> bytes:
    """Encode any protocol Struct to MessagePack."""
    return _encoder.encode(message)


def decode_request(data: bytes) -> Request:
    """Decode a request; raises ``msgspec.DecodeError`` / ``ValidationError`` on bad bytes."""
    return _request_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_reply(data: bytes) -> Reply:
    return _reply_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_change(data: bytes) -> Change:
    return _change_decoder.decode(data)
