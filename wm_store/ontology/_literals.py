"""Protocol values as RDF literals, and the checks of what is inside a typed value.

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

:data:`DATATYPE_KINDS` says which value kinds each datatype of an ``rdfs:range`` stands for.
"""

from __future__ import annotations

import math
from typing import Final

import msgspec
from rdflib import RDF, RDFS, XSD, Namespace, URIRef
from rdflib import Literal as RdfLiteral
from rdflib.term import Node

from wm_store._errors import PropertyValueError
from wm_store.ontology._terms import ALL_KINDS, SKM_IRI, TYPED_KINDS, local_name
from wm_store.protocol import (
    Color,
    Frame,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    TypedValue,
    Value,
)

__all__ = [
    "DATATYPE_KINDS",
    "NAMESPACE",
    "SKM",
    "literal_from_value",
    "value_from_literal",
]

SKM: Final = Namespace(SKM_IRI)
"""The skimesh namespace; ontology IRI ``https://skimesh.dev/ontology``."""
NAMESPACE: Final = SKM

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


# --------------------------------------------------------------------------- range datatypes

DATATYPE_KINDS: Final[dict[URIRef, frozenset[str]]] = {
    **{t: frozenset({"int"}) for t in _INT_TYPES},
    **{t: frozenset({"float"}) for t in _FLOAT_TYPES},
    **{t: frozenset({"string"}) for t in _STRING_TYPES},
    XSD.boolean: frozenset({"bool"}),
    RDFS.Literal: ALL_KINDS,
    SKM.json: frozenset({"list"}),
    **{SKM[k]: frozenset({k}) for k in TYPED_KINDS},
}
"""The value kinds each datatype of a data property's ``rdfs:range`` stands for."""
