"""skimesh transport layer: Zenoh sessions, the key space and the anyio <-> Zenoh bridge.

Start with :func:`open_mesh` (a :class:`MeshConfig` in, a :class:`Mesh` out); keys come from
``mesh.keys`` (:class:`KeySpace`). Every error derives from :class:`MeshlinkError`.
"""

from ._backoff import Backoff
from ._config import (
    DEFAULT_ROUTER_ENDPOINT,
    MeshConfig,
    Mode,
    add_mesh_arguments,
    check_endpoint,
    mesh_config_from_args,
    to_zenoh_config,
)
from ._errors import (
    ConfigError,
    InvalidKeyError,
    MeshlinkError,
    NoReplyError,
    RemoteError,
    SessionError,
)
from ._keyexpr import intersects
from ._keys import KeySpace, check_name
from ._messages import (
    Answer,
    IncomingQuery,
    Liveness,
    MeshStatistics,
    Reply,
    Sample,
    SubscriptionStatistics,
)
from ._publish import MeshPublisher, MeshToken
from ._router import router_config, run_router
from ._serving import Handler
from ._session import Mesh, open_mesh
from ._subscription import Subscription

__all__ = [
    "DEFAULT_ROUTER_ENDPOINT",
    "Answer",
    "Backoff",
    "ConfigError",
    "Handler",
    "IncomingQuery",
    "InvalidKeyError",
    "KeySpace",
    "Liveness",
    "Mesh",
    "MeshConfig",
    "MeshPublisher",
    "MeshStatistics",
    "MeshToken",
    "MeshlinkError",
    "Mode",
    "NoReplyError",
    "RemoteError",
    "Reply",
    "Sample",
    "SessionError",
    "Subscription",
    "SubscriptionStatistics",
    "add_mesh_arguments",
    "check_endpoint",
    "check_name",
    "intersects",
    "mesh_config_from_args",
    "open_mesh",
    "router_config",
    "run_router",
    "to_zenoh_config",
]
