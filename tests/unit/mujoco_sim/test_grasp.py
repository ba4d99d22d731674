"""Grasping with real contacts: attach only when both pads touch, release on open, detect a
lost part, physics-only mode; and a full pick-and-place into the robot's kit box."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import anyio
import pytest

from device_drivers import GraspLostError, Pose2D
from mujoco_sim import (
    SimArm,
    SimBase,
    SimGripper,
    SimWorld,
    WorldOptions,
    running_world,
    sim_devices,
)
from mujoco_sim.motion import tool_down
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

KITTING = (
    Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "kitting" / "scenario.toml"
)
READY = {"shoulder_lift": 0.4, "elbow": 1.5, "wrist_pitch": 1.24}
CARRY = {"shoulder_lift": -0.3, "elbow": 1.6, "wrist_pitch": 1.0}


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as w:
        yield w


@pytest.fixture
async def physics_world() -> AsyncIterator[SimWorld]:
    options = WorldOptions(fast=True, grasp="physics")
    async with running_world(load_scenario(KITTING), options) as w:
        yield w


def devices(world: SimWorld) -> tuple[SimArm, SimGripper, SimBase]:
    found = sim_devices(world, "r1")
    arm, gripper, base = found[("r1", "arm")], found[("r1", "gripper")], found[("r1", "base")]
    assert isinstance(arm, SimArm) and isinstance(gripper, SimGripper)
    assert isinstance(base, SimBase)
    return arm, gripper, base


async def welds_on(world: SimWorld) -> list[str]:
    def read(model: Any, data: Any) -> list[str]:
        names = [str(model.equality(i).name) for i in range(model.neq) if data.eq_active[i]]
        return [name for name in names if "/grasp/" in name]

    return await world.call(read)


async def go_pick(world: SimWorld, part: str) -> float:
    """Drive r1 to Station-1, put the open gripper around ``part``; return the grasp height."""
    arm, _, base = devices(world)
    await base.go_to(Pose2D(0.55, -1.0, 0.0))
    await arm.move_joints(READY)
    p = world.body_pose(part)
    floor = world.body_pose("PartBox-1").z + 0.008
    z = max(p.z, floor + 0.022)  # the pads (4 cm tall) must clear the box floor
    await arm.move_tcp(tool_down(p.x, p.y, z + 0.12), straight=False)
    await arm.move_tcp(tool_down(p.x, p.y, z), speed=0.1)
    return z


async def test_closing_on_air_grasps_nothing(world: SimWorld) -> None:
    arm, gripper, _ = devices(world)
    await arm.move_joints(READY)
    state = await gripper.close()
    assert state.holding == "" and state.pads_in_contact == 0
    assert state.opening < 0.003
    assert await welds_on(world) == []


async def test_close_on_a_part_attaches_it_and_open_releases(world: SimWorld) -> None:
    arm, gripper, _ = devices(world)
    z = await go_pick(world, "Gear-2")
    state = await gripper.close()
    assert state.holding == "Gear-2" and state.pads_in_contact == 2
    assert 0.05 < state.opening < 0.06  # on the 56 mm gear
    assert await welds_on(world) == ["r1/grasp/Gear-2"]
    part = world.body_pose("Gear-2")
    await arm.move_tcp(tool_down(part.x, part.y, z + 0.1), speed=0.2)
    assert world.body_pose("Gear-2").z > part.z + 0.08  # it came along
    assert "Gear-2" in world.snapshot.attached
    await gripper.open()
    assert (await gripper.state()).holding == ""
    assert await welds_on(world) == []
    await world.sleep(1.0)
    assert world.object_in("Gear-2", "PartBox-1")  # fell back into its box


async def test_a_dropped_part_is_detected(world: SimWorld) -> None:
    arm, gripper, _ = devices(world)
    z = await go_pick(world, "Gear-3")
    assert (await gripper.close()).holding == "Gear-3"
    part = world.body_pose("Gear-3")

    def drop(model: Any, data: Any) -> None:
        data.eq_active[model.equality("r1/grasp/Gear-3").id] = 0
        data.ctrl[model.actuator("r1/gripper").id] = 0.085  # and let go

    outcome: list[BaseException] = []
    underway = anyio.Event()  # the part is dropped while the arm carries it, not before

    def moved(fraction: float) -> None:
        if fraction > 0.05:
            underway.set()

    async def carry() -> None:
        try:
            await arm.move_tcp(tool_down(part.x, part.y, z + 0.15), speed=0.05, progress=moved)
        except GraspLostError as exc:
            outcome.append(exc)

    async with anyio.create_task_group() as tg:
        tg.start_soon(carry)
        await underway.wait()
        await world.call(drop)
    assert len(outcome) == 1 and "lost Gear-3" in str(outcome[0])
    assert (await gripper.state()).holding == ""


async def test_pick_and_place_into_the_kit_box(world: SimWorld) -> None:
    arm, gripper, _ = devices(world)
    z = await go_pick(world, "Gear-1")
    assert (await gripper.close()).holding == "Gear-1"
    part = world.body_pose("Gear-1")
    await arm.move_tcp(tool_down(part.x, part.y, z + 0.15), speed=0.2)
    await arm.move_joints(CARRY)
    kit = world.body_pose("KitBox-1")
    await arm.move_tcp(tool_down(kit.x, kit.y, kit.z + 0.15), straight=False)
    await arm.move_tcp(tool_down(kit.x, kit.y, kit.z + 0.07), speed=0.1)
    await gripper.open()
    await arm.move_tcp(tool_down(kit.x, kit.y, kit.z + 0.2), speed=0.2)
    await world.sleep(0.5)
    assert world.object_in("Gear-1", "KitBox-1")
    assert world.objects_in("KitBox-1") == ["Gear-1"]
    assert not world.object_in("Gear-1", "PartBox-1")


async def test_physics_only_mode_never_welds(physics_world: SimWorld) -> None:
    world = physics_world
    arm, gripper, _ = devices(world)
    z = await go_pick(world, "Gear-2")
    state = await gripper.close(force=30.0)
    assert state.holding == "Gear-2"  # both pads touch it
    part = world.body_pose("Gear-2")
    await arm.move_tcp(tool_down(part.x, part.y, z + 0.1), speed=0.1)
    assert await welds_on(world) == []
    assert world.body_pose("Gear-2").z > part.z + 0.08  # carried by friction alone
    assert (await gripper.state()).holding == "Gear-2"
