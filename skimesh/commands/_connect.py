"""Joining the mesh from a command: Zenoh session + world-model client, always closed."""

from __future__ import annotations

import argparse
import logging
from collections.abc import AsyncIterator
from contextlib import AsyncExitStack, asynccontextmanager
from pathlib import Path

from meshlink import Backoff, Mesh, MeshConfig, SessionError, mesh_config_from_args, open_mesh
from wm_store import TransportError, WmClient, ZenohTransport, wait_for_store

from ..errors import UsageError

__all__ = ["mesh_session", "read_terms", "service_mesh", "store_answers", "wm_session"]

ROUTER_POLL_MAX = 5.0
"""Seconds between two tries to reach the router, at most (from 0.5 s, doubling)."""

_log = logging.getLogger("skimesh")


@asynccontextmanager
async def mesh_session(args: argparse.Namespace) -> AsyncIterator[Mesh]:
    async with open_mesh(mesh_config_from_args(args)) as mesh:
        yield mesh


@asynccontextmanager
async def service_mesh(
    config: MeshConfig | argparse.Namespace, who: str, *, every: float = 30.0
) -> AsyncIterator[Mesh]:
    """A long-running service's session. A client started before its router (or while it
    restarts) waits for it, trying again every 0.5 s, then at most every
    :data:`ROUTER_POLL_MAX` s, and says so every ``every`` seconds, as it waits for the store
    (:func:`store_answers`); Ctrl-C stops the wait. A session that listens (a peer or a
    router: a port in use) fails at once."""
    if isinstance(config, argparse.Namespace):
        config = mesh_config_from_args(config)
    backoff = Backoff(0.5, ROUTER_POLL_MAX, every=every)
    async with AsyncExitStack() as stack:
        while True:
            try:
                mesh = await stack.enter_async_context(open_mesh(config))
                break
            except SessionError as e:
                if config.mode != "client" or config.listen:
                    raise
                if backoff.due():
                    _log.info(
                        "%s: waiting for the router (%.0f s so far): %s", who, backoff.waited, e
                    )
            await backoff.wait()
        if backoff.said:
            _log.info("%s: the router answers (after %.0f s)", who, backoff.waited)
        yield mesh


@asynccontextmanager
async def wm_session(args: argparse.Namespace, *, author: str = "cli") -> AsyncIterator[WmClient]:
    """A world-model client with a loaded replica, for one command. It checks against the
    store's ontology (``--ontology`` files belong to the store: refused here)."""
    if getattr(args, "ontology", None):
        raise UsageError(
            "--ontology teaches a store at its start; a client takes the store's ontology. "
            "Teach a running store with `skimesh wm teach FILE.ttl`"
        )
    async with (
        mesh_session(args) as mesh,
        WmClient.connect(ZenohTransport(mesh), author=author, timeout=args.timeout) as client,
    ):
        yield client


async def store_answers(mesh: Mesh, who: str, *, timeout: float) -> None:
    """Wait for the world-model store, saying so every 30 s: a service (an agent, the task
    agent, the event log, the monitor) started before ``skimesh wm`` waits for it, as a ROS 2
    node waits for a service; Ctrl-C stops the wait."""

    def say(waited: float, error: TransportError) -> None:
        _log.info(
            "%s: waiting for the world-model store on mesh %r (%.0f s so far; is `skimesh wm` "
            "running on this mesh, and does the ACL allow this client?)",
            who,
            mesh.keys.mesh,
            waited,
        )
        _log.debug("%s: the store's answer: %s", who, error)

    waited = await wait_for_store(ZenohTransport(mesh), timeout=timeout, say=say)
    if waited > 1.0:
        _log.info("%s: the world-model store answers (after %.0f s)", who, waited)


def read_terms(files: list[str]) -> list[tuple[str, str]]:
    """(file name, Turtle text) of each file of ontology terms; UsageError naming a missing
    one. Reads files: call it before the event loop runs."""
    out = []
    for name in files:
        path = Path(name)
        if not path.is_file():
            raise UsageError(f"no ontology file {name}")
        out.append((path.name, path.read_text(encoding="utf-8")))
    return out
