"""Each motion primitive in the MuJoCo world (kitting scenario, the generated robot r1, fast
mode), judged by the physical outcome: the base pose reached, the tool pose reached (a straight
move stays on its line), a part grasped, lifted and let go with the gripper's opening, and the
typed failures: an unreachable target refused before anything moves, a collision, a grasp lost
mid-motion, a cancel that halts the arm, a timeout that halts it."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Callable
from functools import partial
from typing import Any

import anyio
import pytest

from device_drivers import (
    CollisionError,
    GraspLostError,
    MotionTimeoutError,
    Pose2D,
    UnreachableError,
    WorldPose,
)
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
from skill_agent.primitives import (
    approach,
    close_gripper,
    drive,
    face,
    look_at,
    move_cartesian,
    move_joints,
    move_to,
    navigate_to,
    open_gripper,
    plan_grasp,
    retreat,
)
from skill_agent.primitives.poses import axis, translated
from wm_store.protocol import SizeCylinder
from wm_store.reasoners import Transform

from .test_sim_remote import KITTING, READY
from .test_skills_sim import arm_speed

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

STATION = Pose2D(0.55, -1.0, 0.0)  # Station-1, facing Shelf-1
GEAR = SizeCylinder(radius=0.028, height=0.025)  # the scenario's gears
BOX = (0.20, 0.30, 0.05)  # its part boxes


class R1:
    """Robot r1's in-process drivers in a running kitting world."""

    def __init__(self, world: SimWorld) -> None:
        devices = sim_devices(world, "r1")
        arm, gripper, base = (devices[("r1", d)] for d in ("arm", "gripper", "base"))
        assert isinstance(arm, SimArm) and isinstance(gripper, SimGripper)
        assert isinstance(base, SimBase)
        self.world, self.arm, self.gripper, self.base = world, arm, gripper, base

    async def tcp(self) -> WorldPose:
        return (await self.arm.state()).tcp

    async def joints(self) -> dict[str, float]:
        return (await self.arm.state()).joints

    async def holds_still(self) -> bool:
        """Arm and base stand still: speeds low now, joints and pose unchanged 0.5 s later."""
        if await arm_speed(self.world, "r1") > 0.02:
            return False
        joints, pose = await self.joints(), (await self.base.state()).pose
        await self.world.sleep(0.5)
        later, moved = await self.joints(), (await self.base.state()).pose
        return all(abs(later[j] - q) < 2e-3 for j, q in joints.items()) and (
            math.hypot(moved.x - pose.x, moved.y - pose.y) < 2e-3
        )


@pytest.fixture
async def r1() -> AsyncIterator[R1]:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as world:
        yield R1(world)


@pytest.fixture
async def ready(r1: R1) -> R1:
    """r1 at Station-1 with its arm over the shelf."""
    await navigate_to(r1.base, STATION)
    await move_joints(r1.arm, READY)
    return r1


def once_past(fraction: float, event: anyio.Event) -> Callable[[float], None]:
    """A progress callback that sets ``event`` once the motion is past ``fraction``."""

    def report(done: float) -> None:
        if done > fraction:
            event.set()

    return report


def distance(a: WorldPose, b: WorldPose) -> float:
    return math.dist((a.x, a.y, a.z), (b.x, b.y, b.z))


def z_axis(pose: WorldPose) -> tuple[float, float, float]:
    return axis((pose.qx, pose.qy, pose.qz, pose.qw), 2)


async def grasp_gear(r1: R1, label: str) -> WorldPose:
    """Plan a top-down grasp of a gear from its true pose and approach it; the grasp pose."""
    gear, box = r1.world.body_pose(label), r1.world.body_pose("PartBox-1")
    holder = (Transform((box.x, box.y, box.z + BOX[2] / 2)), BOX)
    grasp = plan_grasp(
        Transform((gear.x, gear.y, gear.z)), GEAR, holder=holder, current=await r1.tcp()
    )
    await approach(r1.arm, grasp.tcp, 0.1)
    return grasp.tcp


# --------------------------------------------------------------------------- base


async def test_navigate_face_and_drive_reach_their_poses(r1: R1) -> None:
    seen: list[float] = []
    reached = await navigate_to(r1.base, STATION, progress=seen.append)
    assert math.hypot(reached.x - STATION.x, reached.y - STATION.y) < 0.01
    assert abs(reached.yaw) < 0.02 and seen == sorted(seen) and seen[-1] == 1.0
    point = (0.55, 0.0, 0.0)  # straight to the left
    turned = await face(r1.base, point)
    assert turned.yaw == pytest.approx(math.pi / 2, abs=0.02)
    assert math.hypot(turned.x - STATION.x, turned.y - STATION.y) < 0.01  # turned in place
    spun = await drive(r1.base, 0.0, 0.0, -0.4, duration=1.0)  # 0.4 rad clockwise
    assert spun.yaw == pytest.approx(turned.yaw - 0.4, abs=0.01)
    with pytest.raises(CollisionError, match="Shelf-1"):
        await navigate_to(r1.base, Pose2D(1.2, -1.0, 0.0))  # into the shelf: refused
    assert await r1.holds_still()


# --------------------------------------------------------------------------- arm


async def test_joint_straight_and_look_at_motions_reach_their_poses(ready: R1) -> None:
    r1 = ready
    assert await r1.joints() == pytest.approx({**await r1.joints(), **READY}, abs=0.01)
    start = translated(await r1.tcp(), (0.0, 0.0, 0.10))  # clear of the shelf top
    await move_to(r1.arm, start)
    assert distance(await r1.tcp(), start) < 0.003
    goal = translated(start, (-0.05, 0.10, 0.05))
    path: list[WorldPose] = []

    def sample(_: float) -> None:
        path.append(r1.world.state(("r1", "arm")).tcp)

    await move_cartesian(r1.arm, goal, speed=0.1, progress=sample)
    assert distance(await r1.tcp(), goal) < 0.003
    assert len(path) >= 5
    line = (goal.x - start.x, goal.y - start.y, goal.z - start.z)
    length = math.sqrt(sum(c * c for c in line))
    for p in path:  # every sample on the line from start to goal
        v = (p.x - start.x, p.y - start.y, p.z - start.z)
        along = sum(a * b for a, b in zip(v, line, strict=True)) / length
        off = math.sqrt(max(0.0, sum(c * c for c in v) - along * along))
        assert off < 0.004 and -0.004 < along < length + 0.004
    target = (1.06, -1.0, 0.70)  # between the part boxes
    commanded = await look_at(r1.arm, target, height=0.25)
    tcp = await r1.tcp()
    assert distance(tcp, commanded) < 0.003
    assert (tcp.x, tcp.y, tcp.z) == pytest.approx((1.06, -1.0, 0.95), abs=0.003)
    assert z_axis(tcp) == pytest.approx((0.0, 0.0, -1.0), abs=0.01)  # looking down at it


async def test_approach_grasp_retreat_and_release_a_part(ready: R1) -> None:
    r1 = ready
    grasp = await grasp_gear(r1, "Gear-1")
    assert distance(await r1.tcp(), grasp) < 0.003
    assert await close_gripper(r1.gripper, expect="Gear-1")
    held = await r1.gripper.state()
    assert held.opening == pytest.approx(2 * GEAR.radius, abs=0.003) and held.pads_in_contact == 2
    before, here = r1.world.body_pose("Gear-1"), await r1.tcp()
    back = await retreat(r1.arm, 0.10)  # back along the approach axis: up
    assert (back.x, back.y, back.z) == pytest.approx((here.x, here.y, here.z + 0.1), abs=1e-3)
    assert distance(await r1.tcp(), back) < 0.003
    lifted = r1.world.body_pose("Gear-1")
    assert lifted.z - before.z == pytest.approx(0.10, abs=0.005)  # the part came along
    await open_gripper(r1.gripper)
    state = await r1.gripper.state()
    assert state.opening == pytest.approx(0.085, abs=0.003) and state.holding == ""
    assert "Gear-1" not in r1.world.snapshot.attached
    with anyio.fail_after(30):
        await r1.world.sleep(0.5)
    assert r1.world.body_pose("Gear-1").z < lifted.z - 0.05  # let go: it fell back


async def test_a_grasp_lost_mid_motion_is_typed_and_halts(ready: R1) -> None:
    r1 = ready
    await grasp_gear(r1, "Gear-2")
    assert await close_gripper(r1.gripper, expect="Gear-2")

    def drop(model: Any, data: Any) -> None:
        data.eq_active[model.equality("r1/grasp/Gear-2").id] = 0
        data.ctrl[model.actuator("r1/gripper").id] = 0.085

    lifting = anyio.Event()
    lost: list[GraspLostError] = []

    async def lift() -> None:
        try:
            await retreat(r1.arm, 0.15, speed=0.05, progress=once_past(0.5, lifting))
        except GraspLostError as exc:
            lost.append(exc)

    async with anyio.create_task_group() as tg:
        tg.start_soon(lift)
        with anyio.fail_after(30):
            await lifting.wait()
        await r1.world.call(drop)
    assert len(lost) == 1 and "lost Gear-2" in str(lost[0])
    assert await r1.holds_still()
    assert r1.world.body_pose("Gear-2").z < (await r1.tcp()).z - 0.05  # it fell back


# --------------------------------------------------------------------------- failures


async def test_an_unreachable_target_fails_before_anything_moves(ready: R1) -> None:
    r1 = ready
    await r1.world.sleep(1.0)  # READY reached within 0.01 rad: let the last mrad settle
    joints = await r1.joints()
    far = tool_down(3.0, 3.0, 0.5)
    for motion in (move_cartesian(r1.arm, far), move_to(r1.arm, far), approach(r1.arm, far, 0.1)):
        with pytest.raises(UnreachableError) as info:
            await motion
        assert info.value.position_error > 1.0
    assert await r1.joints() == pytest.approx(joints, abs=2e-3)
    assert await r1.holds_still()


async def test_cancelling_a_motion_halts_the_arm(ready: R1) -> None:
    r1 = ready
    start = await r1.joints()
    target = {"shoulder_pan": 1.2, "elbow": 0.8}
    under_way = anyio.Event()
    with anyio.CancelScope() as scope:
        async with anyio.create_task_group() as tg:
            tg.start_soon(
                partial(
                    move_joints,
                    r1.arm,
                    target,
                    duration=4.0,
                    progress=once_past(0.3, under_way),
                )
            )
            with anyio.fail_after(30):
                await under_way.wait()
            assert await arm_speed(r1.world, "r1") > 0.05, "really moving"
            scope.cancel()
    assert scope.cancelled_caught
    assert await r1.holds_still()
    pan = (await r1.joints())["shoulder_pan"]
    assert start["shoulder_pan"] + 0.1 < pan < target["shoulder_pan"] - 0.1  # stopped part-way


async def test_a_timeout_halts_the_motion_and_is_typed(ready: R1) -> None:
    r1 = ready
    with pytest.raises(MotionTimeoutError, match="not done within"):
        # 2 minutes of simulated time cannot pass in 0.3 s of wall time (~40x real time)
        await move_joints(r1.arm, {"shoulder_pan": 1.0}, duration=120.0, timeout=0.3)
    assert await r1.holds_still()
    assert abs((await r1.joints())["shoulder_pan"]) < 1.0
    with pytest.raises(MotionTimeoutError):  # an open-ended drive, stopped by its timeout
        await drive(r1.base, -0.1, 0.0, 0.0, timeout=0.3)  # backwards, away from the shelf
    assert not (await r1.base.state()).moving
    assert await r1.holds_still()
