"""Mobile-base primitives: drive to a planar pose, turn to face a point, drive at a velocity.
Cancellable like every primitive (cancellation halts the base, then propagates). Frames and
units: world frame, metres, radians (yaw about +z, 0 = facing +x), speeds in m/s; a velocity
(:func:`drive`) is a twist in the *base* frame. Path planning around furniture happens in the
base driver, which raises :class:`~device_drivers.CollisionError` when no free path
exists (or, driving at a velocity, when the base would hit an obstacle)."""

from __future__ import annotations

import math

from device_drivers import MobileBase, Pose2D, ProgressCallback
from skill_agent.primitives._supervise import supervise
from skill_agent.primitives.poses import Vec3

__all__ = ["drive", "face", "navigate_to"]


async def navigate_to(
    base: MobileBase,
    target: Pose2D,
    *,
    speed: float = 0.5,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> Pose2D:
    """Drive to ``target``; returns the pose reached (as the base reports it)."""
    await supervise(
        base,
        f"{base.name}: go to ({target.x:.2f}, {target.y:.2f}, yaw {target.yaw:.2f})",
        lambda: base.go_to(target, speed=speed, progress=progress),
        timeout=timeout,
    )
    return (await base.state()).pose


async def face(
    base: MobileBase,
    point: Vec3,
    *,
    speed: float = 0.5,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
) -> Pose2D:
    """Turn in place until the base's x axis points at ``point`` (world, m): what a camera
    looking ahead on the base needs to see it. Returns the pose reached."""
    here = (await base.state()).pose
    yaw = math.atan2(point[1] - here.y, point[0] - here.x)
    return await navigate_to(
        base, Pose2D(here.x, here.y, yaw), speed=speed, progress=progress, timeout=timeout
    )


async def drive(
    base: MobileBase,
    vx: float,
    vy: float,
    wz: float,
    *,
    duration: float | None = None,
    timeout: float | None = None,
) -> Pose2D:
    """Drive at the twist ``vx``, ``vy`` (m/s), ``wz`` (rad/s) in the base frame (x forward,
    y left), clamped to the base's limits, for ``duration`` seconds of the device's clock
    (simulated time in the simulation). None: until the base is stopped (by its ``stop()``,
    by cancelling this call, or by ``timeout`` wall-clock seconds, which halts it and raises
    :class:`~device_drivers.MotionTimeoutError`). Returns the pose reached."""
    await supervise(
        base,
        f"{base.name}: drive at ({vx:.2f}, {vy:.2f}, {wz:.2f})",
        lambda: base.set_velocity(vx, vy, wz, duration=duration),
        timeout=timeout,
    )
    return (await base.state()).pose
