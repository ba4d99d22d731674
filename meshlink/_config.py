"""How a process joins the mesh: :class:`MeshConfig`, its command-line flags and its
translation to a ``zenoh.Config``.

Safe defaults, because Zenoh's own listen on every interface and scout by multicast:

* listen endpoints are always set explicitly: routers ``tcp/127.0.0.1:7447`` unless told
  otherwise, peers a random loopback port, clients nothing;
* clients connect to ``tcp/127.0.0.1:7447`` when no connect endpoint is given;
* multicast scouting is off unless ``multicast_scouting`` is set (and then Zenoh's scouting
  delay is left alone; with scouting off it is 0, so a router opens without Zenoh's scouting
  delay);
* Zenoh's shared-memory transport is off unless ``shared_memory`` is set: it maps a 16 MiB
  pool per process (up to three: 16-48 MB of every agent's memory) for messages over 3 KB,
  which the mesh's traffic rarely has, and a process killed by a signal leaves its segments
  in ``/dev/shm`` for good (a robot host that restarts a crashing agent for weeks fills it).

A Zenoh JSON5 file (``config_file``) is loaded first; the fields of :class:`MeshConfig`
override it. Connect and listen endpoints of the file are kept when the matching field is
empty. ``multicast_scouting`` and ``shared_memory`` always win (the file cannot tell "unset"
from "true").

Nothing here blocks (the config file is read synchronously; it is small).
"""

from __future__ import annotations

import argparse
import json
import os
import re
from collections.abc import Callable
from typing import Annotated, Any, Literal, get_args

import msgspec
import zenoh

from ._errors import ConfigError, InvalidKeyError
from ._keys import check_name

__all__ = [
    "DEFAULT_ROUTER_ENDPOINT",
    "MeshConfig",
    "Mode",
    "add_mesh_arguments",
    "check_endpoint",
    "mesh_config_from_args",
    "to_zenoh_config",
]

Mode = Literal["client", "peer", "router"]
MODES: tuple[str, ...] = get_args(Mode)
DEFAULT_ROUTER_ENDPOINT = "tcp/127.0.0.1:7447"
_PEER_LISTEN = "tcp/127.0.0.1:0"  # loopback, port picked by the OS

_ENDPOINT = re.compile(r"(?P<proto>[a-z][a-z0-9-]*)/(?P<addr>[^?#]+)(?:\?[^#]*)?(?:#.*)?", re.S)
_HOST_PORT = re.compile(r"(?:\[[0-9A-Fa-f:.]+(?:%\w+)?\]|[A-Za-z0-9._-]+):(?P<port>\d{1,5})")
_IP_PROTOCOLS = frozenset({"tcp", "udp", "tls", "quic", "ws"})
_OTHER_PROTOCOLS = frozenset({"unixsock-stream", "unixpipe", "serial", "vsock"})
_RUST_LOCATION = re.compile(r"\s+at\s+/\S+\.rs:\d+\.?")


class MeshConfig(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Where and how to join the mesh. Validated when built (``ConfigError``)."""

    mode: Mode = "client"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    config_file: str | None = None
    mesh: str = "default"
    multicast_scouting: bool = False
    lease_ms: Annotated[int, msgspec.Meta(gt=0)] | None = None
    timestamping: bool = False
    shared_memory: bool = False
    """Zenoh's shared-memory transport between processes of one host: off by default (see
    the module doc)."""

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ConfigError(f"mode must be one of {', '.join(MODES)}, not {self.mode!r}")
        for endpoint in self.connect:
            check_endpoint(endpoint, listen=False)
        for endpoint in self.listen:
            check_endpoint(endpoint, listen=True)
        try:
            check_name(self.mesh, "mesh name")
        except InvalidKeyError as e:
            raise ConfigError(str(e)) from None
        if self.lease_ms is not None and self.lease_ms <= 0:
            raise ConfigError(f"lease_ms must be a positive number of ms, not {self.lease_ms}")


def check_endpoint(endpoint: str, *, listen: bool) -> str:
    """Return ``endpoint`` if it is a usable Zenoh endpoint (``<protocol>/<address>``).

    Zenoh itself accepts unknown protocols and ports above 65535 and only fails at open time;
    this catches them early. Port 0 is allowed for listen endpoints only.

    Raises:
        ConfigError: the endpoint is malformed; the message says the expected form.
    """
    side = "listen" if listen else "connect"
    form = "expected <protocol>/<host>:<port>, e.g. tcp/127.0.0.1:7447"
    m = _ENDPOINT.fullmatch(endpoint)
    if m is None or any(c.isspace() for c in endpoint):
        raise ConfigError(f"bad {side} endpoint {endpoint!r}: {form}")
    proto, addr = m.group("proto"), m.group("addr")
    if proto in _OTHER_PROTOCOLS:
        return endpoint
    if proto not in _IP_PROTOCOLS:
        known = ", ".join(sorted(_IP_PROTOCOLS | _OTHER_PROTOCOLS))
        raise ConfigError(f"bad {side} endpoint {endpoint!r}: unknown protocol {proto!r} ({known})")
    hp = _HOST_PORT.fullmatch(addr)
    if hp is None:
        raise ConfigError(f"bad {side} endpoint {endpoint!r}: {form}")
    port = int(hp.group("port"))
    if port > 65535 or (port == 0 and not listen):
        raise ConfigError(f"bad {side} endpoint {endpoint!r}: port {port} is out of range")
    return endpoint


def zenoh_message(error: BaseException) -> str:
    """A Zenoh error message without the Rust source locations it carries."""
    return _RUST_LOCATION.sub("", str(error)).strip()


def _insert(zc: zenoh.Config, key: str, value: Any) -> None:
    try:
        zc.insert_json5(key, json.dumps(value))
    except zenoh.ZError as e:
        raise ConfigError(f"Zenoh rejects {key} = {value!r}: {zenoh_message(e)}") from None


def _load_file(path: str) -> zenoh.Config:
    if not os.path.isfile(path):
        raise ConfigError(f"Zenoh config file {path!r} does not exist")
    try:
        return zenoh.Config.from_file(path)
    except zenoh.ZError as e:
        raise ConfigError(f"cannot load Zenoh config file {path!r}: {zenoh_message(e)}") from None


def _get(zc: zenoh.Config, key: str) -> Any:
    return json.loads(zc.get_json(key))


def to_zenoh_config(cfg: MeshConfig) -> zenoh.Config:
    """Translate ``cfg`` into a ``zenoh.Config`` (see the module docstring for defaults).

    Raises:
        ConfigError: the config file cannot be loaded or Zenoh rejects a value.
    """
    defaults = zenoh.Config()
    zc = _load_file(cfg.config_file) if cfg.config_file else zenoh.Config()
    _insert(zc, "mode", cfg.mode)

    connect: list[str] | None = list(cfg.connect)
    if not connect and _get(zc, "connect/endpoints") != _get(defaults, "connect/endpoints"):
        connect = None  # keep the file's
    elif not connect and cfg.mode == "client":
        connect = [DEFAULT_ROUTER_ENDPOINT]
    if connect is not None:
        _insert(zc, "connect/endpoints", connect)

    listen: list[str] | None = list(cfg.listen)
    if not listen and _get(zc, "listen/endpoints") != _get(defaults, "listen/endpoints"):
        listen = None  # keep the file's
    elif not listen:
        listen = {"router": [DEFAULT_ROUTER_ENDPOINT], "peer": [_PEER_LISTEN]}.get(cfg.mode, [])
    if listen is not None:
        _insert(zc, "listen/endpoints", listen)

    _insert(zc, "scouting/multicast/enabled", cfg.multicast_scouting)
    if not cfg.multicast_scouting and _get(zc, "scouting/delay") is None:
        _insert(zc, "scouting/delay", 0)
    if cfg.lease_ms is not None:
        _insert(zc, "transport/link/tx/lease", cfg.lease_ms)
    if cfg.timestamping:
        _insert(zc, "timestamping/enabled", True)
    _insert(zc, "transport/shared_memory/enabled", cfg.shared_memory)
    return zc


def add_mesh_arguments(
    parser: argparse.ArgumentParser,
    *,
    default_mode: Mode = "client",
    router: bool = False,
    config_type: Callable[[str], str] = str,
    repeat: bool = False,
) -> None:
    """Add the Zenoh flags every long-running command shares: ``--connect`` and ``--listen``
    (both repeatable), ``--config FILE`` (Zenoh JSON5), then ``--mesh`` and ``--mode``; read
    them back with :func:`mesh_config_from_args`.

    ``router=True`` is for ``skimesh router``: ``--connect`` links it to other routers, and
    there is no ``--mesh`` or ``--mode`` (a router carries every mesh and is a router).
    ``config_type`` converts (and may reject, with ``argparse.ArgumentTypeError``) the
    ``--config`` value, e.g. to point a misplaced file at the right flag.

    ``repeat=True`` adds the same flags to a sub-command of a parser that has them already, so
    they may come before or after the sub-command (``skimesh wm --connect E tree`` and
    ``skimesh wm tree --connect E``): the sub-command's copies have no defaults and set only
    what is given, so they never undo what came before them.
    """
    suppress: Any = argparse.SUPPRESS
    sub: dict[str, Any] = {"default": suppress} if repeat else {}
    if router:
        connect_help = "another router to link this one to, repeatable (one router per host)"
        listen_help = (
            f"endpoint to listen on, repeatable (default {DEFAULT_ROUTER_ENDPOINT}: loopback "
            "only; e.g. tcp/0.0.0.0:7447 to accept other hosts)"
        )
    else:
        connect_help = (
            f"router to connect to, repeatable (clients default to {DEFAULT_ROUTER_ENDPOINT})"
        )
        listen_help = (
            "endpoint to listen on, repeatable (routers default to "
            f"{DEFAULT_ROUTER_ENDPOINT}, clients listen on nothing)"
        )
    group = parser.add_argument_group("mesh (Zenoh)")
    group.add_argument("--connect", action="append", metavar="ENDPOINT", help=connect_help, **sub)
    group.add_argument("--listen", action="append", metavar="ENDPOINT", help=listen_help, **sub)
    group.add_argument(
        "--config",
        dest="zenoh_config",
        type=config_type,
        metavar="FILE",
        **sub,
        help="Zenoh JSON5 config file (TLS, auth, ACL...), loaded first; the other flags "
        "override it",
    )
    if router:
        return
    group.add_argument(
        "--mesh",
        metavar="NAME",
        help="mesh name: key prefix skimesh/NAME (default: default)",
        **(sub or {"default": "default"}),
    )
    group.add_argument(
        "--mode",
        choices=MODES,
        help=f"Zenoh mode (default: {default_mode})",
        **(sub or {"default": default_mode}),
    )


def mesh_config_from_args(ns: argparse.Namespace) -> MeshConfig:
    """Build a :class:`MeshConfig` from flags added by :func:`add_mesh_arguments`.

    Raises:
        ConfigError: a flag value is invalid (bad endpoint, mesh name or mode).
    """
    return MeshConfig(
        mode=getattr(ns, "mode", "client"),
        connect=tuple(getattr(ns, "connect", None) or ()),
        listen=tuple(getattr(ns, "listen", None) or ()),
        config_file=getattr(ns, "zenoh_config", None),
        mesh=getattr(ns, "mesh", "default"),
    )
