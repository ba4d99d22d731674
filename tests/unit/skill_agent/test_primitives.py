"""Motion primitives over fake devices (success, typed failures, timeouts, cancellation that
stops the device, refusals that do not, progress) and the pure grasp / release / slot
planning (in a container and on a surface)."""

from __future__ import annotations

import math

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
from skill_agent.primitives import (
    GripperGeometry,
    NoGraspError,
    approach,
    close_gripper,
    drive,
    extents,
    face,
    footprint_radius,
    free_spot,
    free_spots,
    look_at,
    move_cartesian,
    move_joints,
    navigate_to,
    open_gripper,
    plan_grasp,
    release,
    release_pose,
    retreat,
    sub_progress,
    surface_spots,
)
from skill_agent.primitives.poses import axis, to_transform, to_wm_pose, to_world_pose, yaw_of
from tests.unit.skill_agent.test_skills_fakes import (
    FakeArm,
    FakeBase,
    FakeGripper,
    ToyWorld,
)
from wm_store.protocol import Orientation, Pose, Position, SizeCuboid, SizeCylinder, SizeSphere
from wm_store.reasoners import Transform, quat_from_axes, quat_from_yaw

DOWN = WorldPose(0.5, 0.0, 0.9, 1.0, 0.0, 0.0, 0.0)  # tcp z pointing at the floor


@pytest.fixture
def world() -> ToyWorld:
    return ToyWorld()


@pytest.fixture
def arm(world: ToyWorld) -> FakeArm:
    return FakeArm("arm", world, DOWN)


# --------------------------------------------------------------------------- motions


@pytest.mark.anyio
async def test_move_joints_and_cartesian_reach_with_progress(arm: FakeArm) -> None:
    seen: list[float] = []
    await move_joints(arm, {"j0": 0.3}, progress=seen.append)
    target = WorldPose(0.6, 0.1, 0.8, 1.0, 0.0, 0.0, 0.0)
    await move_cartesian(arm, target, progress=seen.append)
    assert arm.joints["j0"] == 0.3 and arm.tcp == target
    assert arm.calls == ["joints", "line"] and seen == [0.5, 1.0, 0.5, 1.0]


@pytest.mark.anyio
async def test_approach_comes_in_along_the_approach_axis(arm: FakeArm) -> None:
    target = WorldPose(0.7, 0.0, 0.75, 1.0, 0.0, 0.0, 0.0)
    seen: list[float] = []
    pre = await approach(arm, target, 0.1, progress=seen.append)
    assert (pre.x, pre.y, pre.z) == pytest.approx((0.7, 0.0, 0.85))  # above: tcp z is down
    assert arm.calls == ["free", "line"] and arm.tcp == target
    assert seen == pytest.approx([0.3, 0.6, 0.8, 1.0])


@pytest.mark.anyio
async def test_approach_along_a_given_direction(arm: FakeArm) -> None:
    target = WorldPose(0.7, 0.0, 0.75, 1.0, 0.0, 0.0, 0.0)
    pre = await approach(arm, target, 0.2, direction=(1.0, 0.0, 0.0))
    assert (pre.x, pre.y, pre.z) == pytest.approx((0.5, 0.0, 0.75))


@pytest.mark.anyio
async def test_retreat_backs_off_along_the_approach_or_a_direction(arm: FakeArm) -> None:
    back = await retreat(arm, 0.1)
    assert back.z == pytest.approx(1.0)
    side = await retreat(arm, 0.2, direction=(0.0, 2.0, 0.0))
    assert (side.y, side.z) == pytest.approx((0.2, 1.0))


@pytest.mark.anyio
async def test_look_at_points_the_tool_down_above_the_point(arm: FakeArm) -> None:
    pose = await look_at(arm, (1.0, 0.5, 0.7), height=0.3)
    assert (pose.x, pose.y, pose.z) == pytest.approx((1.0, 0.5, 1.0))
    assert axis((pose.qx, pose.qy, pose.qz, pose.qw), 2) == pytest.approx((0.0, 0.0, -1.0))


@pytest.mark.anyio
async def test_a_failed_motion_stops_the_device_and_raises_its_error(arm: FakeArm) -> None:
    arm.fail_next["line"] = CollisionError("arm: hit Shelf-1")
    with pytest.raises(CollisionError, match="Shelf-1"):
        await move_cartesian(arm, DOWN)
    assert arm.stops == 1


@pytest.mark.anyio
async def test_an_unreachable_target_is_refused_without_a_stop(arm: FakeArm) -> None:
    arm.fail_next["line"] = UnreachableError(
        position_error=0.5,
        orientation_error=0.0,
        iterations=9,
        solver="fake",
        joints={},
        whole_body=False,
    )
    with pytest.raises(UnreachableError):
        await move_cartesian(arm, DOWN)
    assert arm.stops == 0  # nothing moved; a stop would only reset the held set-points


@pytest.mark.anyio
async def test_a_slow_motion_times_out_and_stops(arm: FakeArm) -> None:
    arm.hold = anyio.Event()
    with pytest.raises(MotionTimeoutError, match=r"not done within 0\.05 s"):
        await move_joints(arm, {"j0": 1.0}, timeout=0.05)
    assert arm.stops == 1


@pytest.mark.anyio
async def test_cancellation_stops_the_device_then_propagates(arm: FakeArm) -> None:
    arm.hold = anyio.Event()
    with anyio.move_on_after(0.05) as scope:
        await approach(arm, DOWN, 0.1)
    assert scope.cancelled_caught and arm.stops == 1 and not arm.moving


@pytest.mark.anyio
async def test_grasp_lost_during_a_motion_is_typed(world: ToyWorld, arm: FakeArm) -> None:
    gripper = FakeGripper("gripper", world, arm)
    world.objects["Gear-1"] = WorldPose(0.5, 0.0, 0.89)
    assert await close_gripper(gripper, expect="Gear-1")
    arm.drop_during = "line"
    with pytest.raises(GraspLostError, match="lost Gear-1"):
        await retreat(arm, 0.1)


@pytest.mark.anyio
async def test_gripper_primitives_report_what_is_held(world: ToyWorld, arm: FakeArm) -> None:
    gripper = FakeGripper("gripper", world, arm)
    assert not await close_gripper(gripper)  # nothing there
    world.objects["Gear-1"] = WorldPose(0.5, 0.0, 0.9)
    assert await close_gripper(gripper, 15.0)
    assert not await close_gripper(gripper, expect="Gear-2")
    await release(gripper, extra=0.01)
    assert gripper.opening == pytest.approx(0.06) and gripper.holding == ""
    await open_gripper(gripper)
    assert gripper.opening == pytest.approx(0.085)


@pytest.mark.anyio
async def test_base_primitives(world: ToyWorld) -> None:
    base = FakeBase("base", world, Pose2D(0.0, 0.0, 0.0))
    reached = await navigate_to(base, Pose2D(1.0, 2.0, 0.5))
    assert reached == Pose2D(1.0, 2.0, 0.5)
    turned = await face(base, (1.0, 3.0, 0.0))
    assert turned.yaw == pytest.approx(math.pi / 2)
    base.hold = anyio.Event()
    with anyio.move_on_after(0.05):
        await navigate_to(base, Pose2D(5.0, 5.0))
    assert base.stops == 1
    with pytest.raises(MotionTimeoutError, match=r"drive at \(0\.10, 0\.00, 0\.00\)"):
        await drive(base, 0.1, 0.0, 0.0, timeout=0.05)  # open-ended: its timeout stops it
    assert base.stops == 2 and base.calls[-1] == "velocity"
    base.hold = None
    assert await drive(base, 0.0, 0.0, 0.3, duration=1.0) == turned  # the fake stays put


def test_sub_progress_maps_into_a_share() -> None:
    seen: list[float] = []
    part = sub_progress(seen.append, 0.5, 0.75)
    assert part is not None
    part(0.0), part(1.0), part(2.0)
    assert seen == [0.5, 0.75, 0.75]
    assert sub_progress(None, 0, 1) is None


# --------------------------------------------------------------------------- poses


def test_pose_conversions_round_trip() -> None:
    q = quat_from_axes((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))
    pose = WorldPose(1.0, 2.0, 3.0, *q)
    back = to_world_pose(to_transform(pose))
    assert (back.x, back.y, back.z, back.qx, back.qy, back.qz, back.qw) == pytest.approx(
        (1, 2, 3, *q)
    )
    wm = to_wm_pose(pose)
    assert to_transform(wm).translation == (1.0, 2.0, 3.0)
    assert yaw_of(quat_from_yaw(0.7)) == pytest.approx(0.7)
    assert axis(q, 2) == pytest.approx((0.0, 0.0, -1.0))


# --------------------------------------------------------------------------- grasps


def _tcp_axes(pose: WorldPose) -> tuple[tuple[float, float, float], ...]:
    q = (pose.qx, pose.qy, pose.qz, pose.qw)
    return tuple(axis(q, i) for i in range(3))


def test_a_top_down_grasp_closes_across_the_narrow_side_of_a_cuboid() -> None:
    bracket = Transform((1.0, -1.0, 0.75))
    grasp = plan_grasp(bracket, SizeCuboid(x=0.03, y=0.05, z=0.04))
    _, y, z = _tcp_axes(grasp.tcp)
    assert z == pytest.approx((0, 0, -1), abs=1e-9) and abs(y[0]) == pytest.approx(1.0)
    assert grasp.width == pytest.approx(0.03) and grasp.strategy == "top-down"
    # pads 2 cm half height + 3 mm clearance above the bottom (0.73): 0.753, above the centre
    assert grasp.tcp.z == pytest.approx(0.753)


def test_a_cylinder_is_grasped_across_its_holders_short_side() -> None:
    box = Transform((1.0, 0.0, 0.7), quat_from_yaw(math.pi / 2))  # long side now along world x
    grasp = plan_grasp(
        Transform((1.0, 0.0, 0.75)),
        SizeCylinder(radius=0.013, height=0.09),
        holder=(box, (0.2, 0.3, 0.05)),
    )
    _, y, _ = _tcp_axes(grasp.tcp)
    assert abs(y[1]) == pytest.approx(1.0)  # the box's x axis: world y
    assert grasp.tcp.z == pytest.approx(0.75)  # tall: the pads at its middle


def test_the_finger_orientation_nearest_the_present_tool_is_chosen() -> None:
    obj, size = Transform((1.0, 0.0, 0.7)), SizeCuboid(x=0.03, y=0.05, z=0.04)
    first = plan_grasp(obj, size)
    q = quat_from_axes((0.0, -1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, -1.0))  # fingers along -x
    flipped = plan_grasp(obj, size, current=WorldPose(0, 0, 1, *q))
    assert _tcp_axes(flipped.tcp)[1][0] == pytest.approx(-1.0)
    assert _tcp_axes(first.tcp)[1][0] == pytest.approx(1.0)


def test_grasp_pose_data_wins_and_records_the_object_in_the_hand() -> None:
    side = Pose(
        Position(-0.045, 0.0, 0.0),
        Orientation(*quat_from_axes((0.0, 0.0, -1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))),
    )
    box = Transform((0.77, -0.4, 0.78))
    grasp = plan_grasp(box, SizeCuboid(x=0.16, y=0.07, z=0.06), grasp_pose=side)
    assert grasp.strategy == "graspPose" and grasp.width == pytest.approx(0.07)
    assert (grasp.tcp.x, grasp.tcp.z) == pytest.approx((0.725, 0.78))
    assert grasp.approach == pytest.approx((1.0, 0.0, 0.0))
    back = to_transform(grasp.tcp).compose(grasp.object_in_tcp)
    assert back.translation == pytest.approx(box.translation)


def test_what_no_grasp_fits_is_refused_with_a_reason() -> None:
    with pytest.raises(NoGraspError, match="neither side fits"):
        plan_grasp(Transform(), SizeCuboid(x=0.1, y=0.2, z=0.1))
    with pytest.raises(NoGraspError, match="no size"):
        plan_grasp(Transform(), None)
    tipped = Transform((0, 0, 0), (math.sin(0.7), 0.0, 0.0, math.cos(0.7)))
    with pytest.raises(NoGraspError, match="tipped over"):
        plan_grasp(tipped, SizeSphere(radius=0.02))
    with pytest.raises(NoGraspError, match="opens 60 mm"):
        plan_grasp(Transform(), SizeSphere(radius=0.03), geometry=GripperGeometry(max_opening=0.06))


def test_sizes_and_footprints() -> None:
    assert extents(SizeCylinder(radius=0.01, height=0.1)) == (0.02, 0.02, 0.1)
    assert extents(SizeSphere(radius=0.01)) == (0.02, 0.02, 0.02)
    assert extents(None) is None
    assert footprint_radius(SizeCuboid(x=0.06, y=0.08, z=0.1)) == pytest.approx(0.05)
    assert footprint_radius(None) == pytest.approx(0.03)


# --------------------------------------------------------------------------- release and slots


def test_release_pose_puts_the_bottom_at_the_target() -> None:
    tcp = WorldPose(1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0)  # pointing down
    held = to_transform(tcp).inverse().compose(Transform((1.0, 0.0, 0.99)))  # centre 1 cm below
    goal = release_pose(tcp, held, (0.4, -1.0, 0.38), height=0.025)
    assert (goal.x, goal.y, goal.z) == pytest.approx((0.4, -1.0, 0.38 + 0.0125 + 0.01))
    assert (goal.qx, goal.qw) == (tcp.qx, tcp.qw)


def test_free_spots_avoid_walls_and_what_is_there() -> None:
    kit = Transform((0.0, 0.0, 0.385))
    size = (0.24, 0.30, 0.07)
    first = free_spot(kit, size, 0.028)
    assert first == pytest.approx((0.0, 0.0, 0.358))
    spots = free_spots(kit, size, 0.028, [((0.0, 0.0, 0.36), 0.028)])
    assert spots and all(math.hypot(x, y) >= 0.056 + 0.012 - 1e-9 for x, y, _ in spots)
    assert all(
        abs(x) <= 0.12 - 0.008 - 0.028 and abs(y) <= 0.15 - 0.008 - 0.028 for x, y, _ in spots
    )
    assert free_spot(kit, size, 0.2) is None


def test_surface_spots_lie_on_the_top_clear_of_edges_and_boxes_nearest_the_robot() -> None:
    shelf = Transform((1.23, -1.0, 0.35))  # the kitting shelf: 0.6 x 1.2 x 0.7 m, centre
    size = (0.6, 1.2, 0.7)
    boxes = [((1.06, -1.25, 0.725), 0.18), ((1.06, -0.75, 0.725), 0.18)]
    spots = surface_spots(shelf, size, 0.028, boxes, edge=0.03, near=(0.55, -1.0, 0.0))
    assert spots and all(z == pytest.approx(0.70) for _, _, z in spots)  # on the top
    assert all(
        abs(x - 1.23) <= 0.3 - 0.03 - 0.028 + 1e-9 and abs(y + 1.0) <= 0.6 - 0.03 - 0.028 + 1e-9
        for x, y, _ in spots
    )
    assert all(
        math.hypot(x - bx, y - by) >= 0.028 + r + 0.012 - 1e-9
        for x, y, _ in spots
        for (bx, by, _), r in boxes
    )
    assert spots[0] == pytest.approx((0.93 + 0.03 + 0.028, -1.0, 0.70))  # front, between boxes
    reach = [math.hypot(x - 0.55, y + 1.0) for x, y, _ in spots]
    assert reach == sorted(reach)
    centred = surface_spots(shelf, size, 0.028)  # nothing near: the centre first
    assert centred[0] == pytest.approx((1.23, -1.0, 0.70))
    assert surface_spots(shelf, (0.05, 0.05, 0.7), 0.028) == []  # too small for the part
