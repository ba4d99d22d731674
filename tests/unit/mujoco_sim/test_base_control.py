"""The mobile base: paths around furniture footprints (pure), and go_to and set_velocity (the
twist in the base frame, the base's limits, stop / replace / busy / collision / bad values) in
the simulation."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from functools import partial
from pathlib import Path

import anyio
import msgspec
import pytest

from device_drivers import CollisionError, CommandError, DeviceBusyError, MotionStoppedError, Pose2D
from mujoco_sim import SimBase, SimWorld, WorldOptions, running_world, sim_devices
from mujoco_sim.control import plan_path
from mujoco_sim.motion import rect_corners, rects_overlap
from scenario import Footprint, load_scenario

KITTING = (
    Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "kitting" / "scenario.toml"
)
HALF = (0.3, 0.225)
PILLAR = Footprint("Pillar-1", 1.0, 0.0, 0.0, 0.2, 0.2)


def test_rectangles_overlap_with_rotation() -> None:
    a = rect_corners(0.0, 0.0, 0.0, 1.0, 0.1)
    assert rects_overlap(a, rect_corners(0.9, 0.0, 0.0, 0.1, 0.1))
    assert not rects_overlap(a, rect_corners(0.0, 0.5, 0.0, 0.1, 0.1))
    assert rects_overlap(a, rect_corners(0.0, 0.5, math.pi / 2, 0.5, 0.1))


def test_a_free_line_is_taken_straight() -> None:
    path = plan_path((0.0, 1.0, 0.0), (2.0, 1.0, 0.5), HALF, [PILLAR])
    assert path == [(0.0, 1.0, 0.0), (2.0, 1.0, 0.5)]


def test_a_blocked_line_gets_a_detour() -> None:
    path = plan_path((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), HALF, [PILLAR])
    assert len(path) == 3
    via = path[1]
    assert abs(via[1]) >= 0.6  # beside the pillar


def test_a_target_inside_furniture_is_refused() -> None:
    with pytest.raises(CollisionError, match="overlaps Pillar-1"):
        plan_path((0.0, 0.0, 0.0), (1.1, 0.0, 0.0), HALF, [PILLAR])


def test_no_free_detour_is_a_collision_error() -> None:
    wall = Footprint("Wall-1", 1.0, 0.0, 0.0, 0.1, 5.0)
    with pytest.raises(CollisionError, match="blocked by Wall-1"):
        plan_path((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), HALF, [wall])


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True)) as w:
        yield w


@pytest.mark.sim
@pytest.mark.anyio
async def test_go_to_reaches_the_pose(world: SimWorld) -> None:
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, SimBase)
    seen: list[float] = []
    await base.go_to(Pose2D(0.0, -1.6, math.pi / 2), progress=seen.append)
    pose = (await base.state()).pose
    assert math.hypot(pose.x - 0.0, pose.y + 1.6) < 0.01
    assert pose.yaw == pytest.approx(math.pi / 2, abs=0.02)
    assert seen == sorted(seen) and seen[-1] == 1.0
    kit = world.body_pose("KitBox-1")  # the kit box rides along, turned with the base
    assert kit.y == pytest.approx(-1.6 - 0.105, abs=0.01)


@pytest.mark.sim
@pytest.mark.anyio
async def test_go_to_into_a_shelf_is_refused(world: SimWorld) -> None:
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, SimBase)
    with pytest.raises(CollisionError, match="Shelf-1"):
        await base.go_to(Pose2D(1.2, -1.0, 0.0))
    assert not (await base.state()).moving


def r1_base(world: SimWorld) -> SimBase:
    base = sim_devices(world, "r1")[("r1", "base")]
    assert isinstance(base, SimBase)
    return base


@pytest.mark.sim
@pytest.mark.anyio
async def test_set_velocity_drives_at_the_twist_in_the_base_frame(world: SimWorld) -> None:
    base = r1_base(world)
    await base.go_to(Pose2D(-0.6, -1.0, math.pi / 2))  # facing +y: base x = world y
    async with anyio.create_task_group() as tg:
        tg.start_soon(partial(base.set_velocity, 0.3, 0.0, 0.0, duration=1.5))
        await world.sleep(1.0)  # ramped up (0.3 s at 1 m/s²), still driving
        mid = await base.state()
    end = await base.state()
    assert mid.moving and mid.velocity.vx == pytest.approx(0.3, abs=0.01)
    assert abs(mid.velocity.vy) < 0.01 and abs(mid.velocity.wz) < 0.01
    assert not end.moving and abs(end.velocity.vx) < 0.02
    # symmetric ramps: 0.3 m/s x 1.5 s, along world +y
    assert (end.pose.x, end.pose.y) == pytest.approx((-0.6, -1.0 + 0.45), abs=0.01)
    assert end.pose.yaw == pytest.approx(math.pi / 2, abs=0.01)


@pytest.mark.sim
@pytest.mark.anyio
async def test_set_velocity_is_clamped_to_the_bases_limits(world: SimWorld) -> None:
    base = r1_base(world)  # RobotSpec: 1 m/s, 1 rad/s, 1 m/s²
    async with anyio.create_task_group() as tg:
        tg.start_soon(partial(base.set_velocity, 3.0, 3.0, 0.0, duration=1.6))
        await world.sleep(0.4)
        early = (await base.state()).velocity.vy
        await world.sleep(0.2)
        later = (await base.state()).velocity.vy
        await world.sleep(0.8)
        fastest = (await base.state()).velocity
    assert later - early == pytest.approx(0.2 / math.sqrt(2), abs=0.02)  # 1 m/s² diagonally
    assert (fastest.vx, fastest.vy) == pytest.approx((0.707, 0.707), abs=0.02)  # 1 m/s
    end = (await base.state()).pose  # 1.6 m along the diagonal
    assert (end.x, end.y) == pytest.approx((-0.6 + 1.131, -1.0 + 1.131), abs=0.02)
    async with anyio.create_task_group() as tg:
        tg.start_soon(partial(base.set_velocity, 0.0, 0.0, -5.0, duration=2.5))
        await world.sleep(2.2)
        assert (await base.state()).velocity.wz == pytest.approx(-1.0, abs=0.02)


@pytest.mark.sim
@pytest.mark.anyio
async def test_stop_ends_an_open_velocity_and_a_new_twist_replaces_it(world: SimWorld) -> None:
    base = r1_base(world)
    ended: list[str] = []
    replaced = anyio.Event()

    async def drive(name: str, wz: float, duration: float | None = None) -> None:
        try:
            await base.set_velocity(0.0, 0.0, wz, duration=duration)
            ended.append(name)
        except MotionStoppedError:
            ended.append(f"{name} stopped")
        if name == "first":
            replaced.set()

    async with anyio.create_task_group() as tg:
        tg.start_soon(drive, "first", 0.5)
        await world.sleep(0.8)
        tg.start_soon(drive, "second", -0.4)
        with anyio.fail_after(10):  # the second twist has taken over (not just been sent)
            await replaced.wait()
        await world.sleep(1.0)
        assert ended == ["first"]  # replaced: returned normally
        assert (await base.state()).velocity.wz == pytest.approx(-0.4, abs=0.02)
        with pytest.raises(DeviceBusyError):  # no go_to while a twist drives the base
            await base.go_to(Pose2D(-0.6, -1.2, 0.0))
        await base.stop()
    assert ended == ["first", "second"]  # stop() is how an open-ended twist ends
    still = await base.state()
    assert not still.moving and abs(still.velocity.wz) < 0.01
    async with anyio.create_task_group() as tg:
        tg.start_soon(drive, "third", 0.5, 5.0)
        await world.sleep(0.5)
        await base.stop()
    assert ended[-1] == "third stopped"  # a duration cut short is a stopped motion
    yaw = (await base.state()).pose.yaw
    await world.sleep(0.5)
    assert (await base.state()).pose.yaw == pytest.approx(yaw, abs=0.005)


@pytest.mark.sim
@pytest.mark.anyio
async def test_set_velocity_refusals_and_collision_halt(world: SimWorld) -> None:
    base = r1_base(world)
    for bad in (
        base.set_velocity(math.nan, 0.0, 0.0),
        base.set_velocity(0.1, 0.0, 0.0, duration=0.0),
    ):
        with pytest.raises(CommandError):
            await bad
    async with anyio.create_task_group() as tg:  # busy while a go_to drives the base
        tg.start_soon(partial(base.go_to, Pose2D(0.55, -1.0, 0.0)))
        await world.sleep(0.3)
        with pytest.raises(DeviceBusyError):
            await base.set_velocity(0.1, 0.0, 0.0)
    with pytest.raises(CollisionError, match="would hit Shelf-1"):  # straight at the shelf
        await base.set_velocity(0.5, 0.0, 0.0)
    state = await base.state()
    assert not state.moving and state.pose.x < 1.23 - 0.3 - 0.3  # clear of its front
    await world.sleep(0.5)
    assert max(map(abs, msgspec.structs.astuple((await base.state()).velocity))) < 0.005
    with anyio.move_on_after(5) as scope:  # cancelling the call stops the base
        async with anyio.create_task_group() as tg:
            tg.start_soon(partial(base.set_velocity, -0.3, 0.0, 0.0))
            await world.sleep(0.6)
            tg.cancel_scope.cancel()
    assert not scope.cancelled_caught
    x = (await base.state()).pose.x
    await world.sleep(0.5)
    assert (await base.state()).pose.x == pytest.approx(x, abs=0.005)
