"""Pausing the simulated devices (fast world): the arm held longer than its own time limits
resumes to its target, a close given to a paused gripper waits for the resume, a base
driving by velocity comes to rest and drives on; every pause answers at rest within the
bound."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import anyio
import pytest

from device_drivers import Arm, Gripper, MobileBase, Pausable
from mujoco_sim import SimWorld, WorldOptions, running_world, sim_devices
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

KITTING = (
    Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "kitting" / "scenario.toml"
)
BOUND = 2.0  # simulated seconds from a pause to rest (the drivers' stated bound)


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as w:
        yield w


async def timed_pause(world: SimWorld, device: Pausable) -> float:
    asked = world.snapshot.time
    with anyio.fail_after(10):
        await device.pause()
    return world.snapshot.time - asked


async def test_an_arm_held_past_its_time_limits_resumes_to_its_target(world: SimWorld) -> None:
    arm = sim_devices(world, "r1")[("r1", "arm")]
    assert isinstance(arm, Arm) and isinstance(arm, Pausable)
    start = (await arm.state()).joints
    target = {"shoulder_pan": start["shoulder_pan"] + 0.8, "elbow": start["elbow"] - 0.6}
    async with anyio.create_task_group() as tg:
        tg.start_soon(lambda: arm.move_joints(target, duration=1.0))
        await world.sleep(0.4)
        assert await timed_pause(world, arm) <= BOUND
        held = (await arm.state()).joints
        assert abs(held["shoulder_pan"] - start["shoulder_pan"]) > 0.05, "on its way"
        assert abs(held["shoulder_pan"] - target["shoulder_pan"]) > 0.05, "not there yet"
        await world.sleep(5.0)  # longer than the move and its 2 s settle limit together
        assert (await arm.state()).joints == pytest.approx(held, abs=1e-3)
        assert (await arm.state()).moving
        await arm.resume()
    end = (await arm.state()).joints
    assert end["shoulder_pan"] == pytest.approx(target["shoulder_pan"], abs=0.01)
    assert end["elbow"] == pytest.approx(target["elbow"], abs=0.01)


async def test_a_close_given_while_paused_waits_for_the_resume(world: SimWorld) -> None:
    """(The fingers close within one batch of the fast world: they are paused first.)"""
    gripper = sim_devices(world, "r1")[("r1", "gripper")]
    assert isinstance(gripper, Gripper) and isinstance(gripper, Pausable)
    wide = (await gripper.state()).opening
    assert await timed_pause(world, gripper) <= BOUND
    closed: list[float] = []

    async def close() -> None:
        closed.append((await gripper.close()).opening)

    async with anyio.create_task_group() as tg:
        tg.start_soon(close)
        await world.sleep(4.0)  # beyond the 3 s limit of a close
        assert (await gripper.state()).opening == pytest.approx(wide, abs=5e-4)
        assert not closed
        await gripper.resume()
    assert closed and closed[0] < 0.003  # nothing between the fingers: they met


async def test_a_base_driving_by_velocity_comes_to_rest_and_drives_on(world: SimWorld) -> None:
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, MobileBase) and isinstance(base, Pausable)
    start = (await base.state()).pose
    async with anyio.create_task_group() as tg:
        tg.start_soon(lambda: base.set_velocity(0.2, 0.0, 0.0, duration=2.0))
        await world.sleep(1.0)
        assert await timed_pause(world, base) <= BOUND
        state = await base.state()
        assert abs(state.velocity.vx) <= 0.005
        await world.sleep(3.0)
        assert (await base.state()).pose.x == pytest.approx(state.pose.x, abs=1e-3)
        await base.resume()
    end = (await base.state()).pose
    assert end.x - start.x == pytest.approx(0.2 * 2.0, abs=0.05)  # the whole 2 s of driving
