"""Robots from URDF files in the simulation: the shipped ``kitting-panda`` scenario, whose
robot ``r2`` is a Franka Panda with its hand (``[robots.model.mjcf] package =
"example-robot-data:panda"``, offline) and ``r1`` a UR5 carrying a Franka hand (one URDF
beside the scenario, ``arm_xml``, a relative path), their chains, tool frames, grippers and pads
derived from the files. The shipped skills navigate, pick a part from a part box on a shelf and
place it into the robot's kit box; the physics confirms it arrived."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import msgspec
import numpy as np
import pytest

from device_drivers import Arm, Gripper, GripperState
from mujoco_sim import sim_devices
from scenario import UR5E_JOINTS
from skill_agent.primitives import close_gripper, move_cartesian, open_gripper
from tests.integration.test_skills_sim import KITTING, Sim, run, simulation
from wm_store.ontology import Rel

pytest.importorskip("cmeel", reason="needs example-robot-data: pip install example-robot-data")
pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIO = Path(__file__).resolve().parents[2] / "configs/scenarios/kitting-panda/scenario.toml"


@pytest.fixture
async def sim() -> AsyncIterator[Sim]:
    async with simulation("kitting-panda") as sim:
        yield sim


async def _pick_and_place(sim: Sim, robot: str, station: str, part: str, kit: str) -> None:
    async with sim.agent(robot, *KITTING, sensors=("Camera-1",)) as agent:
        for skill, params in (
            ("navigate", {"goal": sim[station]}),
            ("pick", {"object": sim[part]}),
        ):
            result = await run(agent, skill, **params)
            assert result.success, f"{skill}: {result.message}"
        state = sim.world.snapshot.states[(robot, "gripper")]
        assert isinstance(state, GripperState)
        assert state.holding == part and state.pads_in_contact == 2
        hand = sim.world.body_pose(f"{robot}/panda_hand")
        assert hand.z - sim.world.body_pose(part).z > 0.05  # carried up, below the hand
        result = await run(agent, "place", object=sim[part], container=sim[kit])
        assert result.success, f"place: {result.message}"
    assert sim.wm.query_relation(sim[kit], Rel.contain, sim[part])
    await sim.world.sleep(0.5)
    assert sim.world.object_in(part, kit), "the ground truth agrees"
    assert part not in sim.world.snapshot.attached


async def test_a_panda_picks_a_bolt_and_places_it_in_its_kit_box(sim: Sim) -> None:
    await _pick_and_place(sim, "r2", "Station-2", "Bolt-1", "KitBox-2")


async def test_a_ur5_with_a_franka_hand_picks_a_gear_and_places_it(sim: Sim) -> None:
    await _pick_and_place(sim, "r1", "Station-1", "Gear-1", "KitBox-1")


async def test_straight_moves_and_the_derived_gripper(sim: Sim) -> None:
    """The UR5's chain from the joined file; a straight tool move tracks the line; the gripper
    (calibrated from the derived pads) opens to a width in metres and closes on nothing."""
    devices = sim_devices(sim.world, "r1")
    arm, gripper = devices[("r1", "arm")], devices[("r1", "gripper")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    assert set((await arm.state()).joints) == set(UR5E_JOINTS)
    tcp = (await arm.state()).tcp
    goal = msgspec.structs.replace(tcp, x=tcp.x + 0.05, y=tcp.y + 0.05, z=tcp.z - 0.1)
    await move_cartesian(arm, goal, speed=0.1)
    reached = (await arm.state()).tcp
    assert np.allclose((reached.x, reached.y, reached.z), (goal.x, goal.y, goal.z), atol=3e-3)
    await gripper.open(0.04)
    assert (await gripper.state()).opening == pytest.approx(0.04, abs=3e-3)
    assert not await close_gripper(gripper)  # nothing between the pads
    assert (await gripper.state()).opening < 0.003
    await open_gripper(gripper)
    assert (await gripper.state()).opening > 0.075
