"""A lost agent's reservations over real Zenoh: when the agent's liveliness token goes, the
store's presence monitor releases the places its robot reserved (``reservedBy``), and keeps
those of robots that are still alive."""

from __future__ import annotations

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from tests.integration.test_wm_presence import wait_until
from wm_store import RobotRegistration, WmClient, ZenohTransport
from wm_store.ontology import Ontology, Prop
from wm_store.protocol import UpdateElement
from wm_store.server import WmStore, serve_store

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]


async def test_a_lost_agent_releases_its_robots_places(
    router_endpoint: str, mesh_config: object
) -> None:
    config: MeshConfig = mesh_config(router_endpoint)  # type: ignore[operator]
    store = await WmStore.open(Ontology.default())
    async with open_mesh(config) as server_mesh, anyio.create_task_group() as tg:
        await tg.start(serve_store, server_mesh, store)
        async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
            r1 = await wm.register_robot(RobotRegistration(agent="r1-agent", robot_label="r1"))
            r2 = await wm.register_robot(RobotRegistration(agent="r2-agent", robot_label="r2"))
            robot1, robot2 = r1["$robot"], r2["$robot"]
            station = await wm.add_element("Station", "Station-1")
            lane = await wm.add_element("Location", "lane", {Prop.robotCapacity: 2})
            token2 = mesh.declare_token(mesh.keys.agent("r2-agent"))
            async with open_mesh(config) as agent_mesh:
                agent_mesh.declare_token(agent_mesh.keys.agent("r1-agent"))
                await wait_until(
                    wm, lambda: wm.get_element(r1["$agent"]).properties.get("available") is True
                )
                await wm.transact(
                    [
                        UpdateElement(id=station, properties={Prop.reservedBy: [robot1]}),
                        UpdateElement(id=lane, properties={Prop.reservedBy: [robot2, robot1]}),
                    ]
                )
            # r1's process is gone: its places are given back, r2's kept

            def reserved(place: str) -> object:
                return wm.get_element(place).properties.get(Prop.reservedBy)

            await wait_until(wm, lambda: reserved(station) == [] and reserved(lane) == [robot2])
            assert wm.get_element(r2["$agent"]).properties.get("available") is True
            token2.undeclare()
            await wait_until(wm, lambda: reserved(lane) == [])
        tg.cancel_scope.cancel()
