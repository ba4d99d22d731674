"""A scenario's scene is loaded once (``skimesh wm --scenario`` / ``import-scenario``): nothing
when it is there, robots an agent registered first reused, unknown names listed."""

from __future__ import annotations

import anyio
import pytest

from scenario import ScenarioError
from scenario.wm import scene_loaded, scene_ops
from skimesh.paths import read_scenario
from wm_store import DeviceSpec, InMemoryTransport, RobotRegistration, WmClient
from wm_store.ontology import Ontology
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


def test_an_unknown_scenario_names_the_known_ones() -> None:
    with pytest.raises(
        ScenarioError, match=r"no scenario 'kiting'.*\(kitting, .*meal, workshop, workshop-shared\)"
    ):
        read_scenario("kiting")


async def test_the_scene_is_loaded_once_and_reuses_a_registered_robot() -> None:
    scenario = read_scenario("kitting")
    store = await WmStore.open(Ontology.default())
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), store.ontology) as wm:
            # an agent started before the scene: its agent, robot and devices are there
            kinds = (("Arm", "arm"), ("Gripper", "gripper"), ("MobileBase", "base"))
            devices = [DeviceSpec(type=t, label=f"r1-{d}") for t, d in kinds]
            registration = RobotRegistration(
                agent="r1", robot_type="MobileManipulator", robot_label="r1", devices=devices
            )
            await wm.register_robot(registration)
            state = wm.replica.state
            assert scene_loaded(scenario, state) == []

            await wm.transact(scene_ops(scenario, state, wm.ontology))
            r1 = sorted(state.elements[i].type for i in state.ids_with_label("r1"))
            assert r1 == ["MobileManipulator", "RobotAgent"]  # the agent, and ONE robot
            for label in ("r1-arm", "r1-gripper", "r1-base", "r1-camera", "Camera-1"):
                assert len(state.ids_with_label(label)) == 1, label
            assert scene_loaded(scenario, state)[:2] == ["Station-1", "Shelf-1"]
            assert scene_ops(scenario, state, wm.ontology) == []
        tg.cancel_scope.cancel()
