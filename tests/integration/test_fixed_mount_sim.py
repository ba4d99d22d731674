"""Fixed robots in the simulation: an arm on a pedestal bolted to the floor (``[robots.model]
mount = "fixed"``), no base. The shipped ``kitting-cell`` scenario (a Franka Panda from the
example-robot-data URDF) and the same cell with the generated arm: the world serves arm,
gripper and wrist camera only, and the shipped skills pick a gear from the part box and place
it into the kit box on the same table (``place_at``); the physics confirms it arrived."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import msgspec
import pytest

from device_drivers import GripperState
from mujoco_sim import sim_devices
from scenario import RobotSpec, Scenario, load_scenario
from skill_agent.skills import Locate, Pick, PlaceAt
from tests.integration.test_skills_sim import Sim, run, simulation
from wm_store.ontology import Rel

pytest.importorskip("cmeel", reason="needs example-robot-data: pip install example-robot-data")
pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIO = Path(__file__).resolve().parents[2] / "configs/scenarios/kitting-cell/scenario.toml"
CELL = (Locate, Pick, PlaceAt)


def generated_cell() -> Scenario:
    """The kitting-cell with the generated 6-joint arm on the pedestal (its shoulder 0.55 m
    high, as on the mobile base)."""
    scenario = load_scenario(SCENARIO)
    [robot] = scenario.robots
    model = RobotSpec(mount="fixed", stand_height=0.55, arm_mount_x=0.0)
    return msgspec.structs.replace(scenario, robots=[msgspec.structs.replace(robot, model=model)])


@pytest.fixture(params=["panda", "generated"])
async def sim(request: pytest.FixtureRequest) -> AsyncIterator[Sim]:
    edit = None if request.param == "panda" else (lambda _: generated_cell())
    async with simulation("kitting-cell", edit=edit) as sim:
        yield sim


async def test_a_fixed_robot_has_no_base(sim: Sim) -> None:
    devices = {("c1", "arm"), ("c1", "gripper"), ("c1", "camera")}  # its wrist camera
    assert set(sim_devices(sim.world, "c1")) == devices
    assert "c1-base" not in sim.ids
    model = sim.world.plant.model
    assert all(not model.joint(j).name.startswith("c1/base") for j in range(model.njnt))
    pedestal = sim.world.body_pose("c1/base")
    assert (pedestal.x, pedestal.y, pedestal.z) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)


async def test_a_fixed_arm_picks_a_gear_and_places_it_into_the_kit_box(sim: Sim) -> None:
    async with sim.agent("c1", *CELL, sensors=("Camera-1",)) as agent:
        result = await run(agent, "pick", object=sim["Gear-1"])
        assert result.success, f"pick: {result.message}"
        state = sim.world.snapshot.states[("c1", "gripper")]
        assert isinstance(state, GripperState)
        assert state.holding == "Gear-1" and state.pads_in_contact == 2
        result = await run(agent, "place_at", object=sim["Gear-1"], container=sim["KitBox-1"])
        assert result.success, f"place_at: {result.message}"
    assert sim.wm.query_relation(sim["KitBox-1"], Rel.contain, sim["Gear-1"])
    await sim.world.sleep(0.5)
    assert sim.world.object_in("Gear-1", "KitBox-1"), "the ground truth agrees"
    assert "Gear-1" not in sim.world.snapshot.attached
    pedestal = sim.world.body_pose("c1/base")
    assert (pedestal.x, pedestal.y) == pytest.approx((0.0, 0.0), abs=1e-9), "it never moved"
