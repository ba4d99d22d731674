"""A lost agent's reservations over real Zenoh: once the agent's liveliness token has been
gone for ``release_after`` seconds, the store's presence monitor releases the places its robot
reserved (``reservedBy``); a token that comes back within that time (a router blip) keeps
them, and so do robots that are still alive."""

from __future__ import annotations

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from tests.integration.test_wm_presence import wait_until
from wm_store import RobotRegistration, WmClient, ZenohTransport
from wm_store.ontology import Ontology, Prop
from wm_store.protocol import UpdateElement
from wm_store.server import PresenceMonitor, WmStore, serve_store

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]

RELEASE_AFTER = 0.5


async def test_a_lost_agent_releases_its_robots_places_a_blip_does_not(
    router_endpoint: str, mesh_config: object
) -> None:
    config: MeshConfig = mesh_config(router_endpoint)  # type: ignore[operator]
    store = await WmStore.open(Ontology.default())
    async with open_mesh(config) as server_mesh, anyio.create_task_group() as tg:
        await tg.start(lambda task_status: serve_store(server_mesh, store, presence=False,
                                                       task_status=task_status))  # fmt: skip
        monitor = PresenceMonitor(server_mesh, store, release_after=RELEASE_AFTER)
        await tg.start(monitor.run)
        async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
            r1 = await wm.register_robot(RobotRegistration(agent="r1-agent", robot_label="r1"))
            r2 = await wm.register_robot(RobotRegistration(agent="r2-agent", robot_label="r2"))
            robot1, robot2 = r1["$robot"], r2["$robot"]
            station = await wm.add_element("Station", "Station-1")
            lane = await wm.add_element("Location", "lane", {Prop.robotCapacity: 2})

            def available(agent: str) -> object:
                return wm.get_element(agent).properties.get("available")

            def reserved(place: str) -> object:
                return wm.get_element(place).properties.get(Prop.reservedBy)

            token2 = mesh.declare_token(mesh.keys.agent("r2-agent"))
            async with open_mesh(config) as agent_mesh:
                agent_mesh.declare_token(agent_mesh.keys.agent("r1-agent"))
                await wait_until(
                    wm, lambda: available(r1["$agent"]) is True and available(r2["$agent"]) is True
                )
                await wm.transact(
                    [
                        UpdateElement(id=station, properties={Prop.reservedBy: [robot1]}),
                        UpdateElement(id=lane, properties={Prop.reservedBy: [robot2, robot1]}),
                    ]
                )
                # r2 blips: gone and back within release_after
                token2.undeclare()
                await wait_until(wm, lambda: available(r2["$agent"]) is False)
                token2 = mesh.declare_token(mesh.keys.agent("r2-agent"))
                await wait_until(wm, lambda: available(r2["$agent"]) is True)
            # r1's process is gone: its places are given back after release_after; by then
            # r2's blip (earlier) would have released r2's place too, had it counted
            await wait_until(wm, lambda: reserved(station) == [] and reserved(lane) == [robot2])
            assert available(r2["$agent"]) is True
            token2.undeclare()
            await wait_until(wm, lambda: reserved(lane) == [])
        tg.cancel_scope.cancel()
