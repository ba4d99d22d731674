"""skimesh world model: an ontology-typed scene graph served as a revisioned, durable Zenoh
key-value store that publishes every change, and an async client that keeps a local replica.

Layers inside the package (pure core first, adapters last)::

    protocol, errors           wire schema and error tree
    ontology*, vocab           the OWL ontology loaded with rdflib, name constants
    state, transactions,       scene graph + indexes, validated all-or-nothing transactions,
    query, resolution          resolve/relations, multi-source property resolution
    rdf, sparql, reasoners     Turtle import/export, read-only SPARQL, spatial/similarity reasoners
    wal, snapshots, durability write-ahead log, snapshots, group commit
    store, service             the authoritative store, request -> reply dispatch
    replica, client, transport the client: local replica, typed API, in-memory/Zenoh transports
    server, presence           the Zenoh adapter of ``skimesh wm`` and agent presence
"""

from .client import WmClient as WmClient
from .errors import CardinalityError as CardinalityError
from .errors import ConflictError as ConflictError
from .errors import ElementNotFoundError as ElementNotFoundError
from .errors import OntologyError as OntologyError
from .errors import RevisionTimeoutError as RevisionTimeoutError
from .errors import TransportError as TransportError
from .errors import ValidationError as ValidationError
from .errors import WmError as WmError
from .ontology import Ontology as Ontology
from .protocol import Element as Element
from .protocol import PropertyFilter as PropertyFilter
from .protocol import Query as Query
from .protocol import Relation as Relation
from .rdf import export_turtle as export_turtle
from .rdf import import_turtle as import_turtle
from .registration import DeviceSpec as DeviceSpec
from .registration import RobotRegistration as RobotRegistration
from .registration import SkillSpec as SkillSpec
from .server import serve_store as serve_store
from .service import WmService as WmService
from .store import StoreConfig as StoreConfig
from .store import WmStore as WmStore
from .transport import InMemoryTransport as InMemoryTransport
from .transport import ZenohTransport as ZenohTransport

__all__ = [
    "CardinalityError",
    "ConflictError",
    "DeviceSpec",
    "Element",
    "ElementNotFoundError",
    "InMemoryTransport",
    "Ontology",
    "OntologyError",
    "PropertyFilter",
    "Query",
    "Relation",
    "RevisionTimeoutError",
    "RobotRegistration",
    "SkillSpec",
    "StoreConfig",
    "TransportError",
    "ValidationError",
    "WmClient",
    "WmError",
    "WmService",
    "WmStore",
    "ZenohTransport",
    "export_turtle",
    "import_turtle",
    "serve_store",
]
