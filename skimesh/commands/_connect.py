"""Joining the mesh from a command: Zenoh session + world-model client, always closed."""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from meshlink import Mesh, mesh_config_from_args, open_mesh
from wm_store import WmClient, ZenohTransport

__all__ = ["mesh_session", "wm_session"]


@asynccontextmanager
async def mesh_session(args: argparse.Namespace) -> AsyncIterator[Mesh]:
    async with open_mesh(mesh_config_from_args(args)) as mesh:
        yield mesh


@asynccontextmanager
async def wm_session(args: argparse.Namespace, *, author: str = "cli") -> AsyncIterator[WmClient]:
    """A world-model client with a loaded replica, for one command."""
    async with (
        mesh_session(args) as mesh,
        WmClient.connect(ZenohTransport(mesh), author=author, timeout=args.timeout) as client,
    ):
        yield client
