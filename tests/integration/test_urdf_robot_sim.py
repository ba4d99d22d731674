"""Robots from one URDF file in the simulation: the kitting scenario's robot ``r2`` built from
``example-robot-data``'s Panda URDF (``[robots.model.mjcf] package = ...``, offline), or a
UR5 with a Franka hand from one URDF beside the scenario (``arm_xml``), its chain, tool
frame, gripper and pads derived from the file. The shipped skills navigate, pick a part from a
part box on a shelf and place it into the robot's kit box; the physics confirms it arrived."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import anyio
import msgspec
import numpy as np
import pytest

from device_drivers import Arm, Gripper, GripperState
from mujoco_sim import WorldOptions, running_world, sim_devices
from scenario import UR5E_JOINTS, parse_scenario
from scenario.wm import scenario_ops
from skill_agent.primitives import close_gripper, move_cartesian, open_gripper
from tests.integration.test_skills_sim import KITTING, Sim, run
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology, Rel
from wm_store.server import WmService, WmStore

pytest.importorskip("cmeel", reason="needs example-robot-data: pip install example-robot-data")
pytestmark = [pytest.mark.sim, pytest.mark.anyio]

ROOT = Path(__file__).resolve().parents[2]
PANDA_TOML = ROOT / "configs/scenarios/kitting-panda/scenario.toml"


#: The shipped scenario with r2 a UR5 carrying a Franka hand: one URDF next to the scenario
#: (a relative path), joined from example-robot-data's UR5 and Panda files.
UR5_HAND = (
    'package = "example-robot-data:panda"',
    'arm_xml = "ur5_franka_hand.urdf"',
    "home = [0.0, -0.85, 0.0, -2.61, 0.0, 1.76, -0.785]",
    "home = [-0.577, -2.374, 2.112, -1.308, -1.571, 2.564]",
)


async def _sim(*replace: str) -> AsyncIterator[Sim]:
    text = PANDA_TOML.read_text()
    for old, new in zip(replace[::2], replace[1::2], strict=True):
        assert old in text
        text = text.replace(old, new)
    scenario = parse_scenario(text, base_dir=PANDA_TOML.parent)
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with (
            running_world(scenario, WorldOptions(fast=True)) as world,
            WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm,
        ):
            reply = await wm.transact(scenario_ops(scenario))
            ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
            yield Sim(world, wm, ids)
        tg.cancel_scope.cancel()


@pytest.fixture
async def panda() -> AsyncIterator[Sim]:
    async for sim in _sim():  # the shipped scenario: r2 is a Panda
        yield sim


@pytest.fixture
async def ur5_hand() -> AsyncIterator[Sim]:
    async for sim in _sim(*UR5_HAND):
        yield sim


async def _pick_and_place(sim: Sim, part: str, hand: str) -> None:
    async with sim.agent("r2", *KITTING, sensors=("Camera-1",)) as r2:
        for skill, params in (
            ("navigate", {"goal": sim["Station-2"]}),
            ("pick", {"object": sim[part]}),
        ):
            result = await run(r2, skill, **params)
            assert result.success, f"{skill}: {result.message}"
        state = sim.world.snapshot.states[("r2", "gripper")]
        assert isinstance(state, GripperState)
        assert state.holding == part and state.pads_in_contact == 2
        assert sim.world.body_pose(hand).z - sim.world.body_pose(part).z > 0.05
        result = await run(r2, "place", object=sim[part], container=sim["KitBox-2"])
        assert result.success, f"place: {result.message}"
    assert sim.wm.query_relation(sim["KitBox-2"], Rel.contain, sim[part])
    await sim.world.sleep(0.5)
    assert sim.world.object_in(part, "KitBox-2"), "the ground truth agrees"
    assert part not in sim.world.snapshot.attached


@pytest.mark.slow
async def test_panda_picks_a_bolt_and_places_it_in_its_kit_box(panda: Sim) -> None:
    await _pick_and_place(panda, "Bolt-1", "r2/panda_hand")


async def test_a_ur5_with_a_franka_hand_from_a_urdf_beside_the_scenario(ur5_hand: Sim) -> None:
    """Derived from the joined file: a straight tool move tracks the line, the gripper opens to
    a width in metres and closes on nothing."""
    devices = sim_devices(ur5_hand.world, "r2")
    arm, gripper = devices[("r2", "arm")], devices[("r2", "gripper")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    assert set((await arm.state()).joints) == set(UR5E_JOINTS)
    tcp = (await arm.state()).tcp
    goal = msgspec.structs.replace(tcp, x=tcp.x + 0.05, y=tcp.y - 0.05, z=tcp.z - 0.1)
    await move_cartesian(arm, goal, speed=0.1)
    reached = (await arm.state()).tcp
    assert np.allclose((reached.x, reached.y, reached.z), (goal.x, goal.y, goal.z), atol=3e-3)
    await gripper.open(0.04)
    assert (await gripper.state()).opening == pytest.approx(0.04, abs=3e-3)
    assert not await close_gripper(gripper)  # nothing between the pads
    assert (await gripper.state()).opening < 0.003
    await open_gripper(gripper)
    assert (await gripper.state()).opening > 0.075
