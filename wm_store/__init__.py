"""skimesh world model: an ontology-typed scene graph served as a revisioned, durable Zenoh
key-value store that publishes every change, and an async client that keeps a local replica.

This face is the client's API and the package's errors::

    async with WmClient.connect(ZenohTransport(mesh)) as wm:
        box = await wm.add_element(Cls.KitBox, label="kit-1")

- :class:`WmClient` (local reads from its :class:`Replica`, writes to the store), the
  transports :class:`WmTransport`, :class:`InMemoryTransport` and :class:`ZenohTransport`,
  and robot registration (:class:`RobotRegistration`, :class:`DeviceSpec`, :class:`SkillSpec`);
- every exception: all derive from :class:`WmError`, each with a stable wire ``code``;
- :func:`display_name`: how plans, progress, output and errors name an element (its label,
  with its id where the two differ); :class:`ChangeWords` and :func:`describe_change`: a
  committed change in words (what an update changed, against the elements before it).

The concepts, each a sub-package whose face is the public path of its names (pure core first,
adapters last)::

    protocol     wire schema: values, elements, ops, requests, replies, changes, codec
    ontology     the OWL ontology loaded with rdflib, name constants (Cls, Rel, Prop, Tpl)
    scene        scene graph + indexes, queries, validated all-or-nothing transactions
    rdf          Turtle import/export, read-only SPARQL
    reasoners    spatial and similarity reasoners, plug-in loading
    durability   write-ahead log, snapshots, group commit
    server       the authoritative store, request -> reply dispatch, its Zenoh serving

Only the adapters talk to the network: ``_zenoh_transport`` (:class:`ZenohTransport`) and
``server/_zenoh``, ``server/_presence`` (:func:`~wm_store.server.serve_store`, agent presence).
The core uses only :mod:`meshlink.rpc`, which opens no session: the error reply every service
speaks, request decoding and handling, and raising an error reply by its code.

The face imports its errors; every other name loads on first use (PEP 562 ``__getattr__``), so
a command that names no client starts without the ontology (rdflib), the store or the reasoners.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._errors import CardinalityError as CardinalityError
from ._errors import ConflictError as ConflictError
from ._errors import CorruptLogError as CorruptLogError
from ._errors import DuplicateIdError as DuplicateIdError
from ._errors import DuplicateLabelError as DuplicateLabelError
from ._errors import ElementNotFoundError as ElementNotFoundError
from ._errors import ForbiddenError as ForbiddenError
from ._errors import HistoryCompactedError as HistoryCompactedError
from ._errors import NameConflictError as NameConflictError
from ._errors import OntologyError as OntologyError
from ._errors import PropertyValueError as PropertyValueError
from ._errors import ProtocolError as ProtocolError
from ._errors import QueryLimitError as QueryLimitError
from ._errors import RelationDomainError as RelationDomainError
from ._errors import RemoteError as RemoteError
from ._errors import RevisionTimeoutError as RevisionTimeoutError
from ._errors import StorageError as StorageError
from ._errors import TransportError as TransportError
from ._errors import TreeShapeError as TreeShapeError
from ._errors import UnknownClassError as UnknownClassError
from ._errors import UnknownPropertyError as UnknownPropertyError
from ._errors import UnknownRelationError as UnknownRelationError
from ._errors import UnknownTemplateError as UnknownTemplateError
from ._errors import ValidationError as ValidationError
from ._errors import WmError as WmError
from ._lazy import lazy_getattr

if TYPE_CHECKING:
    from ._batches import transact_in_batches as transact_in_batches
    from ._client import WmClient as WmClient
    from ._describe import ChangeWords as ChangeWords
    from ._describe import describe_change as describe_change
    from ._describe_values import value_text as value_text
    from ._registration import DeviceSpec as DeviceSpec
    from ._registration import RobotRegistration as RobotRegistration
    from ._registration import SkillSpec as SkillSpec
    from ._registration import registration_ops as registration_ops
    from ._registration import unregistration_ops as unregistration_ops
    from ._replica import Replica as Replica
    from ._replica import ReplicaStats as ReplicaStats
    from ._transport import InMemoryTransport as InMemoryTransport
    from ._transport import WmTransport as WmTransport
    from ._zenoh_transport import ZenohTransport as ZenohTransport
    from ._zenoh_transport import wait_for_store as wait_for_store
    from .scene._names import display_name as display_name

__getattr__ = lazy_getattr(  # the names imported on first use (PEP 562), and their modules
    __name__,
    {
        "transact_in_batches": "._batches",
        "WmClient": "._client",
        "ChangeWords": "._describe",
        "describe_change": "._describe",
        "value_text": "._describe_values",
        "DeviceSpec": "._registration",
        "RobotRegistration": "._registration",
        "SkillSpec": "._registration",
        "registration_ops": "._registration",
        "unregistration_ops": "._registration",
        "Replica": "._replica",
        "ReplicaStats": "._replica",
        "InMemoryTransport": "._transport",
        "WmTransport": "._transport",
        "wait_for_store": "._zenoh_transport",
        "ZenohTransport": "._zenoh_transport",
        "display_name": ".scene._names",
    },
)


__all__ = [
    "CardinalityError",
    "ChangeWords",
    "ConflictError",
    "CorruptLogError",
    "DeviceSpec",
    "DuplicateIdError",
    "DuplicateLabelError",
    "ElementNotFoundError",
    "ForbiddenError",
    "HistoryCompactedError",
    "InMemoryTransport",
    "NameConflictError",
    "OntologyError",
    "PropertyValueError",
    "ProtocolError",
    "QueryLimitError",
    "RelationDomainError",
    "RemoteError",
    "Replica",
    "ReplicaStats",
    "RevisionTimeoutError",
    "RobotRegistration",
    "SkillSpec",
    "StorageError",
    "TransportError",
    "TreeShapeError",
    "UnknownClassError",
    "UnknownPropertyError",
    "UnknownRelationError",
    "UnknownTemplateError",
    "ValidationError",
    "WmClient",
    "WmError",
    "WmTransport",
    "ZenohTransport",
    "describe_change",
    "display_name",
    "registration_ops",
    "transact_in_batches",
    "unregistration_ops",
    "value_text",
    "wait_for_store",
]
