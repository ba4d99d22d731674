"""A Zenoh router in this Python process (what ``skimesh router`` runs).

The eclipse-zenoh wheel opened in ``router`` mode is a complete router; no ``zenohd`` is
needed. It loads no plugins (a ``storage_manager`` section in a config file is ignored).
"""

from __future__ import annotations

from collections.abc import Sequence

import anyio
import anyio.abc

from ._config import DEFAULT_ROUTER_ENDPOINT, MeshConfig
from ._session import open_mesh

__all__ = ["router_config", "run_router"]


def router_config(
    listen: Sequence[str] = (),
    *,
    connect: Sequence[str] = (),
    config_file: str | None = None,
) -> MeshConfig:
    """The :class:`MeshConfig` of a router listening on ``listen`` and optionally linked to
    other routers (``connect``). Without ``listen``: the config file's listen endpoints if it
    sets some, else ``tcp/127.0.0.1:7447`` (loopback only). Multicast scouting stays off.

    Raises:
        ConfigError: an endpoint is malformed.
    """
    return MeshConfig(
        mode="router",
        # empty with a config file: to_zenoh_config keeps the file's endpoints or falls back
        # to the same loopback default
        listen=tuple(listen) or (() if config_file else (DEFAULT_ROUTER_ENDPOINT,)),
        connect=tuple(connect),
        config_file=config_file,
    )


async def run_router(
    listen: Sequence[str] = (),
    *,
    connect: Sequence[str] = (),
    config_file: str | None = None,
    task_status: anyio.abc.TaskStatus[str] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Run a router until cancelled, then close it. Reports started (with the router's Zenoh
    id) once its listeners are bound, so ``await tg.start(run_router, [...])`` returns when
    clients can connect.

    Raises:
        ConfigError: bad endpoints or config file.
        SessionError: the router cannot listen (e.g. the port is in use).
    """
    config = router_config(listen, connect=connect, config_file=config_file)
    async with open_mesh(config) as mesh:
        task_status.started(mesh.zid)
        await anyio.sleep_forever()
