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

A refused request answers :class:`meshlink.rpc.ErrorReply` (in :data:`Reply`), the error every
skimesh service speaks: ``code`` is a :class:`~wm_store.WmError` code or one of meshlink's
standard codes (``bad_request``, ``too_large``, ``internal``). Messages are encoded with
:func:`meshlink.rpc.encode`.

The schema is split by what a message is: ``_values`` (typed values, elements, relations,
class and template definitions), ``_ops`` (transaction ops), ``_changes`` (the change stream),
``_requests``, ``_replies`` and ``_codec`` (the decoders).
"""

from ._changes import Change as Change
from ._changes import ClassDefined as ClassDefined
from ._changes import Delta as Delta
from ._changes import ElementPut as ElementPut
from ._changes import ElementRemoved as ElementRemoved
from ._changes import OntologyDelta as OntologyDelta
from ._changes import RelationAdded as RelationAdded
from ._changes import RelationRemoved as RelationRemoved
from ._changes import TemplateDefined as TemplateDefined
from ._changes import TermsDefined as TermsDefined
from ._codec import decode_change as decode_change
from ._codec import decode_reply as decode_reply
from ._codec import decode_request as decode_request
from ._ops import AddElement as AddElement
from ._ops import DefineClass as DefineClass
from ._ops import DefineTemplate as DefineTemplate
from ._ops import DefineTerms as DefineTerms
from ._ops import Observe as Observe
from ._ops import Op as Op
from ._ops import RemoveElement as RemoveElement
from ._ops import SetRelation as SetRelation
from ._ops import UnsetRelation as UnsetRelation
from ._ops import UpdateElement as UpdateElement
from ._replies import CardinalityReply as CardinalityReply
from ._replies import CardinalityViolation as CardinalityViolation
from ._replies import ChangesReply as ChangesReply
from ._replies import CompiledOntologyReply as CompiledOntologyReply
from ._replies import ElementsReply as ElementsReply
from ._replies import InfoReply as InfoReply
from ._replies import OntologyReply as OntologyReply
from ._replies import RelationsReply as RelationsReply
from ._replies import Reply as Reply
from ._replies import SnapshotReply as SnapshotReply
from ._replies import SparqlReply as SparqlReply
from ._replies import TransactReply as TransactReply
from ._requests import ChangesSince as ChangesSince
from ._requests import CheckCardinality as CheckCardinality
from ._requests import Comparator as Comparator
from ._requests import GetCompiledOntology as GetCompiledOntology
from ._requests import GetElements as GetElements
from ._requests import GetOntology as GetOntology
from ._requests import Info as Info
from ._requests import Parent as Parent
from ._requests import PropertyFilter as PropertyFilter
from ._requests import Query as Query
from ._requests import Relations as Relations
from ._requests import Request as Request
from ._requests import Resolve as Resolve
from ._requests import Snapshot as Snapshot
from ._requests import Sparql as Sparql
from ._requests import Transact as Transact
from ._values import SCHEMA_VERSION as SCHEMA_VERSION
from ._values import ClassDef as ClassDef
from ._values import Color as Color
from ._values import Element as Element
from ._values import Frame as Frame
from ._values import Observation as Observation
from ._values import Orientation as Orientation
from ._values import Pose as Pose
from ._values import Position as Position
from ._values import Relation as Relation
from ._values import SizeCuboid as SizeCuboid
from ._values import SizeCylinder as SizeCylinder
from ._values import SizeSphere as SizeSphere
from ._values import Struct_ as Struct_
from ._values import TemplateDef as TemplateDef
from ._values import TermsDef as TermsDef
from ._values import TypedValue as TypedValue
from ._values import Value as Value

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
    "Comparator",
    "CompiledOntologyReply",
    "DefineClass",
    "DefineTemplate",
    "DefineTerms",
    "Delta",
    "Element",
    "ElementPut",
    "ElementRemoved",
    "ElementsReply",
    "Frame",
    "GetCompiledOntology",
    "GetElements",
    "GetOntology",
    "Info",
    "InfoReply",
    "Observation",
    "Observe",
    "OntologyDelta",
    "OntologyReply",
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
    "TermsDef",
    "TermsDefined",
    "Transact",
    "TransactReply",
    "TypedValue",
    "UnsetRelation",
    "UpdateElement",
    "Value",
    "decode_change",
    "decode_reply",
    "decode_request",
]
