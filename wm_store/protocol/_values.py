"""Values and scene-graph records of the wire schema: typed values (FRIEND II sub-symbolic
data), :data:`Value`, :class:`Observation`, :class:`Element`, :class:`Relation`, and the class
and template definitions taught at run time."""

from __future__ import annotations

from typing import Annotated, TypeAlias

from msgspec import Meta, Struct

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


class TermsDef(Struct, frozen=True, kw_only=True):
    """Ontology terms taught as Turtle: classes, relations, data properties, cardinalities,
    templates. Teaching only adds; ``source`` says where the terms came from (a file name, a
    scenario, an agent, ``cli``) for ``skimesh wm ontology`` and error messages."""

    turtle: str
    source: str = ""


class TemplateDef(Struct, frozen=True, kw_only=True):
    """A default individual: a named template with default properties (SkiROS
    ``getDefaultElement``)."""

    name: str
    type: str
    label: str = ""
    properties: dict[str, Value] = {}
