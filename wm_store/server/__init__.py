"""The store side of the world model (``skimesh wm``).

- :class:`WmStore` (with :class:`StoreConfig`): the authoritative store: scene state, ontology
  with its run-time extensions, durable log, bounded change history. Transport-free.
- :class:`WmService`: request -> reply dispatch over a store, independent of the transport;
  it never raises for bad input (every refusal is a ``meshlink.rpc.ErrorReply``).
- :func:`serve_store` and :class:`PresenceMonitor`: the Zenoh adapters, which serve the store
  on the mesh and keep each Agent's ``available`` flag equal to its liveliness token. They
  (``_zenoh``, ``_presence``) are the only modules here that import ``meshlink``.
"""

from ._presence import AVAILABLE as AVAILABLE
from ._presence import PresenceMonitor as PresenceMonitor
from ._service import MAX_REQUEST_BYTES as MAX_REQUEST_BYTES
from ._service import WmService as WmService
from ._store import ChangeListener as ChangeListener
from ._store import StoreConfig as StoreConfig
from ._store import WmStore as WmStore
from ._zenoh import serve_store as serve_store

__all__ = [
    "AVAILABLE",
    "MAX_REQUEST_BYTES",
    "ChangeListener",
    "PresenceMonitor",
    "StoreConfig",
    "WmService",
    "WmStore",
    "serve_store",
]
