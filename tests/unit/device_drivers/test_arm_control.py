"""The simulated arm: joint moves, straight tool lines, whole-body reach, refusals, stop and
cancellation bring it to a halt that holds."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import numpy as np
import pytest

from device_drivers.drivers import SimArm, SimBase, sim_devices
from device_drivers.errors import (
    CommandError,
    DeviceBusyError,
    MotionStoppedError,
    UnreachableError,
)
from device_drivers.interfaces import Arm
from device_drivers.motion_math import tool_down
from device_drivers.scenario_load import load_scenario
from device_drivers.world import SimWorld, WorldOptions, running_world

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

KITTING = (
    Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "kitting" / "scenario.toml"
)
READY = {"shoulder_lift": 0.4, "elbow": 1.5, "wrist_pitch": 1.24}


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as w:
        yield w


def arm_of(world: SimWorld, robot: str = "r1") -> SimArm:
    arm = sim_devices(world, robot)[(robot, "arm")]
    assert isinstance(arm, SimArm) and isinstance(arm, Arm)
    return arm


async def joint_speed(world: SimWorld, robot: str = "r1") -> float:
    def read(model: Any, data: Any) -> float:
        dofs = [model.joint(f"{robot}/{j}").dofadr[0] for j in ("shoulder_lift", "elbow")]
        return float(np.abs(data.qvel[dofs]).max())

    return await world.call(read)


async def test_move_joints_reaches_the_target_with_progress(world: SimWorld) -> None:
    arm = arm_of(world)
    seen: list[float] = []
    await arm.move_joints(READY, progress=seen.append)
    state = await arm.state()
    for name, value in READY.items():
        assert state.joints[name] == pytest.approx(value, abs=0.01)
    assert state.joints["shoulder_pan"] == pytest.approx(0.0, abs=0.01)
    assert not state.moving
    assert seen == sorted(seen) and seen[-1] == 1.0 and len(seen) > 5
    await arm.move_joints({"r1/elbow": 1.2}, duration=0.5)  # full names work too
    assert (await arm.state()).joints["elbow"] == pytest.approx(1.2, abs=0.01)


async def test_move_tcp_follows_a_straight_line(world: SimWorld) -> None:
    arm = arm_of(world)
    await arm.move_joints(READY)
    start = (await arm.state()).tcp
    goal = tool_down(start.x + 0.10, start.y + 0.15, start.z - 0.05, yaw=math.pi / 4)
    a, b = np.array([start.x, start.y, start.z]), np.array([goal.x, goal.y, goal.z])
    worst = 0.0

    def check(_: float) -> None:
        nonlocal worst
        tcp = world.state(("r1", "arm")).tcp
        p = np.array([tcp.x, tcp.y, tcp.z])
        s = float(np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        worst = max(worst, float(np.linalg.norm(p - (a + s * (b - a)))))

    await arm.move_tcp(goal, speed=0.15, progress=check)
    end = (await arm.state()).tcp
    assert math.dist((end.x, end.y, end.z), b) < 3e-3
    assert worst < 5e-3


async def test_whole_body_reaches_beyond_the_arm(world: SimWorld) -> None:
    arm = arm_of(world)
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, SimBase)
    far = tool_down(0.6, -1.0, 0.6)  # 1.2 m ahead of the base: out of the arm's reach alone
    with pytest.raises(UnreachableError, match="whole_body"):
        await arm.move_tcp(far, straight=False)
    await arm.move_joints(READY)
    await arm.move_tcp(far, straight=False, whole_body=True)
    tcp = (await arm.state()).tcp
    assert math.dist((tcp.x, tcp.y, tcp.z), (0.6, -1.0, 0.6)) < 5e-3
    assert (await base.state()).pose.x > -0.5  # the base moved forward


async def test_unreachable_target_moves_nothing(world: SimWorld) -> None:
    arm = arm_of(world)
    before = (await arm.state()).joints
    with pytest.raises(UnreachableError):
        await arm.move_tcp(tool_down(3.0, 3.0, 0.5))
    assert (await arm.state()).joints == pytest.approx(before, abs=1e-3)


async def test_bad_commands_are_refused(world: SimWorld) -> None:
    arm = arm_of(world)
    with pytest.raises(CommandError, match="did you mean 'elbow'"):
        await arm.move_joints({"elbw": 1.0})
    with pytest.raises(CommandError, match="outside its limits"):
        await arm.move_joints({"elbow": 4.0})


async def test_a_second_motion_is_refused_while_one_runs(world: SimWorld) -> None:
    arm = arm_of(world)
    async with anyio.create_task_group() as tg:
        tg.start_soon(arm.move_joints, READY)
        await world.sleep(0.1)
        with pytest.raises(DeviceBusyError, match="stop it first"):
            await arm.move_joints({"elbow": 0.3})


async def test_stop_mid_motion_halts_and_holds(world: SimWorld) -> None:
    arm = arm_of(world)
    outcome: list[BaseException] = []

    async def move() -> None:
        try:
            await arm.move_joints({"shoulder_lift": 1.2, "elbow": 1.5}, duration=3.0)
        except MotionStoppedError as exc:
            outcome.append(exc)

    async with anyio.create_task_group() as tg:
        tg.start_soon(move)
        await world.sleep(1.0)
        assert await joint_speed(world) > 0.2  # really moving
        stopped_at = world.snapshot.time
        await arm.stop()
        halted_at = world.snapshot.time
    assert outcome and "stopped" in str(outcome[0])
    assert halted_at - stopped_at < 0.5  # stop-to-halt, simulated seconds
    assert await joint_speed(world) < 0.02
    held = (await arm.state()).joints
    await world.sleep(1.0)
    assert (await arm.state()).joints == pytest.approx(held, abs=2e-3)
    assert not (await arm.state()).moving


async def test_cancelling_a_motion_halts_the_arm(world: SimWorld) -> None:
    arm = arm_of(world)
    async with anyio.create_task_group() as tg:
        tg.start_soon(partial(arm.move_joints, {"shoulder_lift": 1.2, "elbow": 1.5}, duration=3.0))
        await world.sleep(1.0)
        tg.cancel_scope.cancel()  # the move halts the arm before it lets the cancellation go
    await world.sleep(0.1)
    assert await joint_speed(world) < 0.05
    held = (await arm.state()).joints
    assert held["shoulder_lift"] < 1.1  # it did not carry on to the target
    await world.sleep(0.5)
    assert (await arm.state()).joints == pytest.approx(held, abs=2e-3)
    await arm.move_joints(READY)  # and it takes new commands
