"""Agent presence over real Zenoh: the WM's ``available`` flag follows liveliness tokens."""

from __future__ import annotations

from collections.abc import Callable

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from wm_store import RobotRegistration, WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.server import WmStore, serve_store

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]


async def wait_until(wm: WmClient, condition: Callable[[], bool], timeout: float = 10.0) -> None:
    """Wait, change by change, until ``condition()`` holds on the replica."""
    with anyio.fail_after(timeout):
        async with wm.watch() as changes:
            while not condition():
                await changes.__anext__()


async def test_available_follows_the_agent_token(router_endpoint: str, mesh_config: object) -> None:
    config: MeshConfig = mesh_config(router_endpoint)  # type: ignore[operator]
    store = await WmStore.open(Ontology.default())
    async with (
        open_mesh(config) as server_mesh,
        anyio.create_task_group() as tg,
    ):
        await tg.start(serve_store, server_mesh, store)
        async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
            ids = await wm.register_robot(RobotRegistration(agent="r1-agent", robot_label="r1"))
            agent = ids["$agent"]

            def available() -> object:
                return wm.get_element(agent).properties.get("available")

            # Registered but no token: the store corrects the flag.
            await wait_until(wm, lambda: available() is False)
            token = mesh.declare_token(mesh.keys.agent("r1-agent"))
            await wait_until(wm, lambda: available() is True)
            token.undeclare()
            await wait_until(wm, lambda: available() is False)
            # An agent whose whole session ends (as when its process dies) is seen too.
            async with open_mesh(config) as agent_mesh:
                agent_mesh.declare_token(agent_mesh.keys.agent("r1-agent"))
                await wait_until(wm, lambda: available() is True)
            await wait_until(wm, lambda: available() is False)
        tg.cancel_scope.cancel()
