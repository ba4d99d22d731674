"""The simulated arm: joint moves, straight tool lines, whole-body reach, refusals, joint moves
routed around the robot's own base (or refused before they move), stop and cancellation bring
it to a halt that holds."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import mujoco
import numpy as np
import pytest

from device_drivers import (
    Arm,
    ArmState,
    CollisionError,
    CommandError,
    DeviceBusyError,
    MotionStoppedError,
    UnreachableError,
)
from device_drivers.protocol import MoveTcp
from mujoco_sim import Plant, SimArm, SimBase, SimWorld, WorldOptions, running_world, sim_devices
from mujoco_sim.control import ArmController, Job
from mujoco_sim.control import _arm as arm_control
from mujoco_sim.motion import tool_down
from mujoco_sim.physics import set_joint_positions
from scenario import load_scenario

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


async def test_a_joint_move_through_its_own_base_detours_or_is_refused(world: SimWorld) -> None:
    """From beside the base to the other side, the straight joint path would swing the arm
    through the base: the move goes through the rest posture (arm up) instead. A move that
    would end inside the base is refused with CollisionError before anything moves."""
    arm = arm_of(world)
    left = {"shoulder_pan": -1.5, "shoulder_lift": -1.4, "elbow": -1.8, "wrist_pitch": 1.0}
    await arm.move_joints(left)
    lifts: list[float] = []

    def seen(_: float) -> None:
        state = world.snapshot.states[("r1", "arm")]
        assert isinstance(state, ArmState)
        lifts.append(state.joints["shoulder_lift"])

    await arm.move_joints({**left, "shoulder_pan": 1.5}, progress=seen)
    state = await arm.state()
    assert state.joints["shoulder_pan"] == pytest.approx(1.5, abs=0.01)
    assert min(abs(v) for v in lifts) < 0.2, "it passed the rest posture"
    with pytest.raises(CollisionError, match=r"r1-arm: no collision-free joint move.*r1/base"):
        await arm.move_joints({"shoulder_pan": 0.0, "shoulder_lift": -2.2, "elbow": 0.0})
    # refused before anything moved (the world's clock runs beside the test, so the time it
    # took says nothing on a loaded machine; the joints do)
    assert (await arm.state()).joints == pytest.approx(state.joints, abs=2e-3)


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


def _line_setpoints(monkeypatch: pytest.MonkeyPatch, ahead: int, nudge: bool) -> list[Any]:
    """The set-points of every tick of three straight moves in a bare plant (arm only,
    whole-body, one out of reach that fails on its way), with the tracker's points worked out
    ``ahead`` ticks at a time; ``nudge`` shifts the clock once (a tick at an unexpected time)."""
    monkeypatch.setattr(arm_control, "_AHEAD", ahead)
    plant = Plant(load_scenario(KITTING))
    arm = plant.controllers[("r1", "arm")]
    assert isinstance(arm, ArmController)
    m, d = plant.model, plant.data
    set_joint_positions(m, d, {f"r1/{j}": v for j, v in READY.items()})
    mujoco.mj_forward(m, d)
    seen: list[Any] = []
    start = arm.state().tcp
    for goal, whole in (
        (tool_down(start.x + 0.08, start.y - 0.1, start.z - 0.06), False),
        (tool_down(start.x + 0.25, start.y, start.z - 0.1, yaw=0.3), True),
        (tool_down(start.x + 0.9, start.y, start.z), False),
    ):
        job = Job(arm.key, MoveTcp(goal, speed=0.3, whole_body=whole))
        arm.start(job, float(d.time))
        for tick in range(600):
            if nudge and tick == 37:
                d.time += 1e-4
            arm.tick(float(d.time))
            seen.append(d.ctrl.copy())
            if job.finished:
                break
            mujoco.mj_step(m, d, nstep=plant.steps_per_tick)
        assert job.finished
        seen.append(type(job.error).__name__)
    outcomes = [x for x in seen if isinstance(x, str)]
    assert outcomes == ["NoneType", "NoneType", "UnreachableError"]
    return seen


@pytest.mark.parametrize("nudge", [False, True])
def test_straight_moves_worked_out_ahead_are_the_same(
    monkeypatch: pytest.MonkeyPatch, nudge: bool
) -> None:
    """The tracker's points of the next ticks are computed together: the set-points are the
    very numbers computed one tick at a time, also when a tick comes at another time."""
    one_by_one = _line_setpoints(monkeypatch, 1, nudge)
    ahead = _line_setpoints(monkeypatch, 25, nudge)
    assert len(one_by_one) == len(ahead) > 100
    for a, b in zip(one_by_one, ahead, strict=True):
        if isinstance(a, str):
            assert a == b
        else:
            np.testing.assert_array_equal(a, b)
