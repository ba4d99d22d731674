"""Arm motion primitives: joint moves, straight tool moves, approach / retreat, look-at.

All are ``async`` and cancellable (cancellation stops the arm, then propagates), report
progress (fraction 0..1) through an optional callback, and fail with the device layer's typed
errors: :class:`~device_drivers.UnreachableError` (no IK solution; raised before the arm
moves), :class:`~device_drivers.CollisionError`,
:class:`~device_drivers.MotionTimeoutError` (the device's limit or ``timeout`` seconds
of wall-clock time), :class:`~device_drivers.GraspLostError` (a held object was lost
during the motion). See :mod:`skill_agent.primitives`.

Frames and units: world frame, metres, radians, quaternions ``(x, y, z, w)``; speeds in m/s of
the tool centre point (tcp). The tcp's z axis is the approach direction. IK runs inside the
arm driver (off the event loop); nothing here blocks.
"""

from __future__ import annotations

from collections.abc import Mapping

from device_drivers import Arm, ProgressCallback, WorldPose
from skill_agent.primitives._supervise import sub_progress, supervise
from skill_agent.primitives.poses import Vec3, axis, cross, rotated_z, translated, unit
from wm_store.reasoners import quat_from_axes

__all__ = ["approach", "look_at", "move_cartesian", "move_joints", "move_to", "retreat"]

APPROACH_SHARE = 0.6
"""Share of :func:`approach`'s progress taken by the free move to the pre-grasp pose."""


async def move_joints(
    arm: Arm,
    target: Mapping[str, float],
    *,
    duration: float | None = None,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> None:
    """Move to joint positions (rad or m, by joint name) on a smooth trajectory lasting
    ``duration`` s (default: from the joints' speed limits)."""
    await supervise(
        arm,
        f"{arm.name}: joint move",
        lambda: arm.move_joints(target, duration=duration, progress=progress),
        timeout=timeout,
    )


async def move_to(
    arm: Arm,
    target: WorldPose,
    *,
    speed: float = 0.25,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> None:
    """Bring the tcp to ``target`` by a joint-space motion (the path of the tool is not a
    line; use it in free space). The arm driver checks the joint path against the robot
    itself (arm, base, deck) and, if it collides, takes another IK solution of ``target`` or
    a detour through the arm's home posture;
    :class:`~device_drivers.CollisionError` when none is free."""
    await supervise(
        arm,
        f"{arm.name}: move to {_text(target)}",
        lambda: arm.move_tcp(target, straight=False, speed=speed, progress=progress),
        timeout=timeout,
    )


async def move_cartesian(
    arm: Arm,
    target: WorldPose,
    *,
    speed: float = 0.1,
    whole_body: bool = False,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> None:
    """Move the tcp along the straight line (and orientation slerp) to ``target`` at
    ``speed`` m/s; ``whole_body``: the base may move too."""
    await supervise(
        arm,
        f"{arm.name}: straight move to {_text(target)}",
        lambda: arm.move_tcp(
            target, straight=True, speed=speed, whole_body=whole_body, progress=progress
        ),
        timeout=timeout,
    )


async def approach(
    arm: Arm,
    target: WorldPose,
    offset: float,
    *,
    direction: Vec3 | None = None,
    speed: float = 0.08,
    free_speed: float = 0.25,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> WorldPose:
    """Go to ``target`` from ``offset`` m back along ``direction`` (the direction of the
    final straight motion, world; default: the target's approach axis, tcp z): a free move to
    that pre-pose, then a straight move in. Returns the pre-pose (where :func:`retreat` can
    go back to)."""
    a = rotated_z(target) if direction is None else unit(direction)
    pre = translated(target, (-a[0] * offset, -a[1] * offset, -a[2] * offset))
    await move_to(
        arm,
        pre,
        speed=free_speed,
        progress=sub_progress(progress, 0.0, APPROACH_SHARE),
        timeout=timeout,
    )
    await move_cartesian(
        arm,
        target,
        speed=speed,
        progress=sub_progress(progress, APPROACH_SHARE, 1.0),
        timeout=timeout,
    )
    return pre


async def retreat(
    arm: Arm,
    distance: float,
    *,
    direction: Vec3 | None = None,
    speed: float = 0.08,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> WorldPose:
    """Move the tcp ``distance`` m in a straight line along ``direction`` (world; default:
    back along its approach axis). Returns the pose reached."""
    here = (await arm.state()).tcp
    d = unit(direction) if direction is not None else _back(here)
    target = translated(here, (d[0] * distance, d[1] * distance, d[2] * distance))
    await move_cartesian(arm, target, speed=speed, progress=progress, timeout=timeout)
    return target


async def look_at(
    arm: Arm,
    point: Vec3,
    *,
    height: float = 0.30,
    speed: float = 0.25,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> WorldPose:
    """Put the tcp ``height`` m above ``point`` (world), pointing down at it, so that a wrist
    camera (which looks along the approach axis) has the point in the middle of its view. The
    tcp keeps its present heading. Returns the pose commanded."""
    here = (await arm.state()).tcp
    down: Vec3 = (0.0, 0.0, -1.0)
    heading = _level_x(here)
    y_axis = cross(down, heading)
    pose = quat_from_axes(heading, y_axis, down)
    target = WorldPose(point[0], point[1], point[2] + height, *pose)
    await move_to(arm, target, speed=speed, progress=progress, timeout=timeout)
    return target


def _back(pose: WorldPose) -> Vec3:
    a = rotated_z(pose)
    return (-a[0], -a[1], -a[2])


def _level_x(pose: WorldPose) -> Vec3:
    """The tcp's x axis projected on the floor (or, if vertical, its z axis), unit."""
    q = (pose.qx, pose.qy, pose.qz, pose.qw)
    for index in (0, 2, 1):
        v = axis(q, index)
        if abs(v[0]) + abs(v[1]) > 1e-6:
            return unit((v[0], v[1], 0.0))
    return (1.0, 0.0, 0.0)


def _text(pose: WorldPose) -> str:
    return f"({pose.x:.3f}, {pose.y:.3f}, {pose.z:.3f})"
