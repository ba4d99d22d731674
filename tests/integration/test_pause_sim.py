"""Pausing a run that moves, in the MuJoCo simulation (fast mode), through the agent core:
navigate, pick and place each paused mid-motion come to rest within the stated bound and stay
there while held (velocities ~0, positions unchanged over simulated seconds), then resume and
finish ``ok`` with their goal state; a run stopped while paused ends ``preempted`` with its
devices halted and free; and the same pause of a navigate through a remote device server over
Zenoh."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
import pytest

from device_drivers import Arm, BaseState, Gripper, MobileBase
from device_drivers.remote import connect_devices, serve_devices
from meshlink import open_mesh
from mujoco_sim import sim_devices
from skill_agent.protocol import RunResult, StartRun
from skill_agent.runtime import AgentCore, SkillEntry
from tests.conftest import MeshConfigFactory
from tests.integration.test_skills_sim import KITTING, Sim, arm_speed, simulation, when
from wm_store.ontology import Rel
from wm_store.protocol import Value

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

BOUND = 2.0
"""Simulated seconds from the pause request to the devices at rest (docs/guides)."""


@pytest.fixture
async def kitting() -> AsyncIterator[Sim]:
    async with simulation("kitting") as sim:
        yield sim


def devices(sim: Sim) -> tuple[Arm, Gripper, MobileBase]:
    found = sim_devices(sim.world, "r1")
    arm, gripper, base = found[("r1", "arm")], found[("r1", "gripper")], found[("r1", "base")]
    assert isinstance(arm, Arm) and isinstance(gripper, Gripper)
    assert isinstance(base, MobileBase)
    return arm, gripper, base


def still(state: BaseState) -> bool:
    v = state.velocity
    return max(abs(v.vx), abs(v.vy), abs(v.wz)) <= 0.005


async def pause_when_moving(
    sim: Sim, core: AgentCore, run_id: str, moving: anyio.Event, *, base: bool = False
) -> float:
    """Wait for ``moving``, check the motion is real, pause the run; the simulated seconds the
    pause took (its reply comes once the devices are at rest)."""
    with anyio.fail_after(60):
        await moving.wait()
    if base:
        assert not still(await devices(sim)[2].state()), "really driving"
    else:
        assert await arm_speed(sim.world, "r1") > 0.05, "really moving"
    asked = sim.world.snapshot.time
    with anyio.fail_after(10):
        await core.pause(run_id)
    took = sim.world.snapshot.time - asked
    assert core.status(run_id).state == "paused"
    return took


async def assert_held(sim: Sim, core: AgentCore, run_id: str) -> None:
    """The robot stays where it is for 2 simulated seconds, its motion clock stopped."""
    arm, _, base = devices(sim)
    joints, pose = (await arm.state()).joints, (await base.state()).pose
    assert await arm_speed(sim.world, "r1") < 0.01
    assert still(await base.state())
    await sim.world.sleep(2.0)
    assert (await arm.state()).joints == pytest.approx(joints, abs=1e-3)
    later = (await base.state()).pose
    assert math.hypot(later.x - pose.x, later.y - pose.y) < 1e-3
    assert abs(later.yaw - pose.yaw) < 2e-3
    assert await arm_speed(sim.world, "r1") < 0.01 and still(await base.state())
    assert core.status(run_id).state == "paused" and core.status(run_id).result is None


async def resume_and_wait(core: AgentCore, run_id: str) -> RunResult:
    await core.resume(run_id)
    with anyio.fail_after(60):
        return await core.wait(run_id)


async def run_ok(core: AgentCore, skill: str, **params: Any) -> None:
    started = await core.start(StartRun(skill=skill, params=params))
    with anyio.fail_after(60):
        result = await core.wait(started.run_id)
    assert result.success, f"{skill}: {result.message}"


async def paused_navigate(sim: Sim, r1: AgentCore, speed: float = 0.5) -> None:
    """Navigate to Station-1, paused while driving: held, resumed, at the goal."""
    driving = when(r1, lambda e: e.step == "drive" and e.fraction > 0.3)
    params: dict[str, Value] = {"goal": sim["Station-1"], "speed": speed}
    started = await r1.start(StartRun(skill="navigate", params=params))
    took = await pause_when_moving(sim, r1, started.run_id, driving, base=True)
    assert took <= BOUND
    await assert_held(sim, r1, started.run_id)
    result = await resume_and_wait(r1, started.run_id)
    assert result.success, result.message
    assert sim.wm.query_relation(sim["r1"], Rel.at, sim["Station-1"])
    state = await devices(sim)[2].state()
    goal = sim.wm.spatial.world_pose(sim["Station-1"]).position
    assert math.hypot(goal.x - state.pose.x, goal.y - state.pose.y) < 0.02, "at the goal"


async def test_a_paused_navigate_stops_the_base_and_resumes_to_its_goal(kitting: Sim) -> None:
    async with kitting.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        await paused_navigate(kitting, r1)


async def test_a_paused_pick_holds_the_arm_and_resumes_to_the_grasp(kitting: Sim) -> None:
    sim = kitting
    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        await run_ok(r1, "navigate", goal=sim["Station-1"])
        approaching = when(r1, lambda e: e.step == "approach" and e.fraction > 0.1)
        started = await r1.start(StartRun(skill="pick", params={"object": sim["Gear-3"]}))
        took = await pause_when_moving(sim, r1, started.run_id, approaching)
        assert took <= BOUND
        await assert_held(sim, r1, started.run_id)
        result = await resume_and_wait(r1, started.run_id)
    assert result.success, result.message
    assert (await devices(sim)[1].state()).holding == "Gear-3"
    assert sim.wm.query_relation(sim["r1-gripper"], Rel.contain, sim["Gear-3"])


async def test_a_paused_place_holds_the_arm_and_resumes_into_the_box(kitting: Sim) -> None:
    sim = kitting
    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        await run_ok(r1, "navigate", goal=sim["Station-1"])
        await run_ok(r1, "pick", object=sim["Gear-1"])
        carrying = when(r1, lambda e: e.step == "approach" and e.fraction > 0.1)
        params: dict[str, Value] = {"object": sim["Gear-1"], "container": sim["KitBox-1"]}
        started = await r1.start(StartRun(skill="place", params=params))
        took = await pause_when_moving(sim, r1, started.run_id, carrying)
        assert took <= BOUND
        await assert_held(sim, r1, started.run_id)
        assert (await devices(sim)[1].state()).holding == "Gear-1", "still carried"
        result = await resume_and_wait(r1, started.run_id)
    assert result.success, result.message
    assert sim.wm.query_relation(sim["KitBox-1"], Rel.contain, sim["Gear-1"])
    await sim.world.sleep(0.5)
    assert sim.world.object_in("Gear-1", "KitBox-1"), "the ground truth agrees"


async def test_a_run_stopped_while_paused_ends_with_its_devices_halted_and_free(
    kitting: Sim,
) -> None:
    sim = kitting
    arm, gripper, _ = devices(sim)
    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        await run_ok(r1, "navigate", goal=sim["Station-1"])
        approaching = when(r1, lambda e: e.step == "approach" and e.fraction > 0.1)
        started = await r1.start(StartRun(skill="pick", params={"object": sim["Gear-3"]}))
        await pause_when_moving(sim, r1, started.run_id, approaching)
        with anyio.fail_after(20):
            result = await r1.stop(started.run_id)
    assert result.reason == "preempted"
    assert await arm_speed(sim.world, "r1") < 0.05
    state = await gripper.state()
    assert state.holding == "" and state.opening > 0.08  # on_preempt ran: the gripper is open
    held = (await arm.state()).joints
    await sim.world.sleep(0.5)
    assert (await arm.state()).joints == pytest.approx(held, abs=2e-3)
    with anyio.fail_after(10):  # no hold left: a new motion runs at once
        await arm.move_joints({"elbow": held["elbow"] - 0.1}, duration=0.5)


@asynccontextmanager
async def remote_agent(sim: Sim, endpoint: str, mesh_config: MeshConfigFactory) -> Any:
    """An agent for r1 whose drivers are remote proxies of the world's devices, served on
    another Zenoh session."""
    async with (
        open_mesh(mesh_config(endpoint)) as server,
        open_mesh(mesh_config(endpoint)) as client,
        anyio.create_task_group() as tg,
    ):
        await tg.start(serve_devices, server, sim_devices(sim.world, "r1"))
        proxies = await connect_devices(client, "r1")
        drivers = {sim.ids[d.name]: d for d in proxies.values()}
        core = AgentCore(
            name="r1",
            wm=sim.wm,
            skills={s.description.name: SkillEntry(s.description, s, "") for s in KITTING},
            devices=drivers,
            robot=sim.ids["r1"],
            preempt_timeout=3.0,
        )
        await tg.start(core.run)
        yield core
        tg.cancel_scope.cancel()


@pytest.mark.zenoh
async def test_a_navigate_paused_through_a_remote_device_server(
    kitting: Sim, router_endpoint: str, mesh_config: MeshConfigFactory
) -> None:
    async with remote_agent(kitting, router_endpoint, mesh_config) as r1:
        # slowly: the fast world runs far ahead of the wall clock, and the progress that
        # triggers the pause crosses Zenoh twice first
        await paused_navigate(kitting, r1, speed=0.05)
